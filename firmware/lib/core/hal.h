// The device core's only view of the hardware. The AVR build implements it in
// firmware/src (board.cpp); the host tests implement it with fakes. Every call must
// return within a bounded time: drivers enforce their own deadlines.
#pragma once
#include <stdint.h>

namespace dev {

constexpr uint8_t kChannels = 3;

// What the outputs should be; the board turns setpoints into regulator PWM duty.
struct Outputs {
  int16_t setpoint_dkpa[kChannels];  // gauge vacuum, 0.1 kPa, <= 0
  uint8_t pump_mask;                 // bit i: pump of channel i on
  uint8_t valve_mask;                // bit i: chamber i connected to vacuum (0 vents it)
};

class Hal {
 public:
  virtual uint32_t micros() = 0;  // wraps every ~71.6 min
  virtual uint32_t millis() = 0;
  virtual void apply_outputs(const Outputs& out) = 0;
  // ADS1115 single-shot conversion of AINch with the configured PGA and data rate, in two
  // halves so that other work overlaps the ~1.2 ms conversion: adc_start() begins it,
  // adc_finish() waits for it (bounded) and reads the counts. False when the chip did not
  // answer or the conversion missed its deadline.
  virtual bool adc_start(uint8_t ch) = 0;
  virtual bool adc_finish(int16_t* counts) = 0;
  virtual void adc_configure(uint8_t pga_code, uint8_t rate_code) = 0;
  // BNO055 Euler angles (heading, roll, pitch) in 1/16 degree and system calibration (0..3).
  virtual bool imu_read(int16_t euler_16[3], uint8_t* sys_cal) = 0;
  virtual bool adc_present() = 0;
  virtual bool imu_present() = 0;
  // Serial link: read one byte (-1 when none), write bytes (may block for a reply),
  // and free space in the transmit buffer (telemetry is dropped rather than blocking).
  virtual int16_t serial_read() = 0;
  virtual void serial_write(const uint8_t* data, uint8_t n) = 0;
  virtual uint8_t serial_tx_free() = 0;
  virtual uint8_t eeprom_read(uint16_t addr) = 0;
  virtual void eeprom_write(uint16_t addr, uint8_t value) = 0;  // skips unchanged bytes
  virtual void request_reset() = 0;                             // after the reply has been sent
  virtual uint16_t free_stack() = 0;                            // never-touched stack bytes
  virtual uint8_t reset_cause() = 0;                            // MCUSR at boot
  // PWM duty 0..255 on an Arduino pin (the analogue estimate output); duty 0 drives it low.
  virtual void analog_out(uint8_t pin, uint8_t duty) {
    (void)pin;
    (void)duty;
  }
};

}  // namespace dev
