// dev::Hal on the Uno: Timer0 clock, pump/valve/regulator pins, ADS1115 and BNO055 over
// the deadline-guarded TWI driver, the UART (uart.h), EEPROM, AVR watchdog reset.
#pragma once
#include <stdint.h>

#include "ads1115.h"
#include "bno055.h"
#include "hal.h"

class Board : public dev::Hal {
 public:
  Board();
  static void outputs_safe();  // every output pin driven to its off level
  void begin();                // serial, I2C, sensors (BNO055 boot wait included)

  uint32_t micros() PORT_OVERRIDE;
  uint32_t millis() PORT_OVERRIDE;
  void apply_outputs(const dev::Outputs& out) PORT_OVERRIDE;
  bool adc_start(uint8_t ch) PORT_OVERRIDE;
  bool adc_finish(int16_t* counts) PORT_OVERRIDE;
  void adc_configure(uint8_t pga_code, uint8_t rate_code) PORT_OVERRIDE;
  bool imu_read(int16_t euler_16[3], uint8_t* sys_cal) PORT_OVERRIDE;
  bool adc_present() PORT_OVERRIDE;
  bool imu_present() PORT_OVERRIDE;
  int16_t serial_read() PORT_OVERRIDE;
  void serial_write(const uint8_t* data, uint8_t n) PORT_OVERRIDE;
  uint8_t serial_tx_free() PORT_OVERRIDE;
  uint8_t eeprom_read(uint16_t addr) PORT_OVERRIDE;
  void eeprom_write(uint16_t addr, uint8_t value) PORT_OVERRIDE;
  void request_reset() PORT_OVERRIDE;
  uint16_t free_stack() PORT_OVERRIDE;
  uint8_t reset_cause() PORT_OVERRIDE;
  void analog_out(uint8_t pin, uint8_t duty) PORT_OVERRIDE;

 private:
  Ads1115 adc_;
  Bno055 imu_;
};
