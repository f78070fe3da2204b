// The device core's only view of the hardware. The AVR build implements it in
// firmware/src (board.cpp); the host tests implement it with fakes. Every call must
// return within a bounded time: drivers enforce their own deadlines.
#pragma once
#include <stdint.h>

#include "ports.h"

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
  PORT_FN uint32_t micros() PORT_ABSTRACT;  // wraps every ~71.6 min
  PORT_FN uint32_t millis() PORT_ABSTRACT;
  PORT_FN void apply_outputs(const Outputs& out) PORT_ABSTRACT;
  // ADS1115 single-shot conversion of AINch with the configured PGA and data rate, in two
  // halves so that other work overlaps the ~1.2 ms conversion: adc_start() begins it,
  // adc_finish() waits for it (bounded) and reads the counts. False when the chip did not
  // answer or the conversion missed its deadline.
  PORT_FN bool adc_start(uint8_t ch) PORT_ABSTRACT;
  PORT_FN bool adc_finish(int16_t* counts) PORT_ABSTRACT;
  PORT_FN void adc_configure(uint8_t pga_code, uint8_t rate_code) PORT_ABSTRACT;
  // BNO055 Euler angles (heading, roll, pitch) in 1/16 degree and system calibration (0..3).
  PORT_FN bool imu_read(int16_t euler_16[3], uint8_t* sys_cal) PORT_ABSTRACT;
  PORT_FN bool adc_present() PORT_ABSTRACT;
  PORT_FN bool imu_present() PORT_ABSTRACT;
  // Serial link: read one byte (-1 when none), write bytes (may block for a reply),
  // and free space in the transmit buffer (telemetry is dropped rather than blocking).
  PORT_FN int16_t serial_read() PORT_ABSTRACT;
  PORT_FN void serial_write(const uint8_t* data, uint8_t n) PORT_ABSTRACT;
  PORT_FN uint8_t serial_tx_free() PORT_ABSTRACT;
  PORT_FN uint8_t eeprom_read(uint16_t addr) PORT_ABSTRACT;
  PORT_FN void eeprom_write(uint16_t addr, uint8_t value) PORT_ABSTRACT;  // skips unchanged bytes
  PORT_FN void request_reset() PORT_ABSTRACT;                             // after the reply has been sent
  PORT_FN uint16_t free_stack() PORT_ABSTRACT;                            // never-touched stack bytes
  PORT_FN uint8_t reset_cause() PORT_ABSTRACT;                            // MCUSR at boot
  // PWM duty 0..255 on an Arduino pin (the analogue estimate output); duty 0 drives it low.
#if PORTS_STATIC
  void analog_out(uint8_t pin, uint8_t duty);
#else
  virtual void analog_out(uint8_t pin, uint8_t duty) {  // boards without it ignore it
    (void)pin;
    (void)duty;
  }
#endif
};

}  // namespace dev
