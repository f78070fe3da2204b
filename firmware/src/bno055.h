// BNO055 absolute orientation sensor: bring-up into NDOF fusion mode and Euler angles.
// Datasheet timings: ~650 ms from power-on to the first I2C answer, 19 ms to switch into
// CONFIG mode, 7 ms from CONFIG to any operating mode. Euler angles in 1/16 degree.
#pragma once
#include <stdint.h>

class Bno055 {
 public:
  explicit Bno055(uint8_t addr) : addr_(addr), present_(false) {}
  // Waits up to boot_ms for the chip id 0xA0 (the chip may still be booting), then
  // selects page 0, normal power, degrees, NDOF. False when absent.
  bool begin(uint16_t boot_ms = 800);
  // heading, roll, pitch in 1/16 degree; sys_cal is the system calibration (0..3).
  bool read(int16_t euler_16[3], uint8_t* sys_cal);
  bool present() const { return present_; }

 private:
  bool write8(uint8_t reg, uint8_t value);
  uint8_t addr_;
  bool present_;
};
