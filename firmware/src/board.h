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

  uint32_t micros() override;
  uint32_t millis() override;
  void apply_outputs(const dev::Outputs& out) override;
  bool adc_start(uint8_t ch) override;
  bool adc_finish(int16_t* counts) override;
  void adc_configure(uint8_t pga_code, uint8_t rate_code) override;
  bool imu_read(int16_t euler_16[3], uint8_t* sys_cal) override;
  bool adc_present() override;
  bool imu_present() override;
  int16_t serial_read() override;
  void serial_write(const uint8_t* data, uint8_t n) override;
  uint8_t serial_tx_free() override;
  uint8_t eeprom_read(uint16_t addr) override;
  void eeprom_write(uint16_t addr, uint8_t value) override;
  void request_reset() override;
  uint16_t free_stack() override;
  uint8_t reset_cause() override;
  void analog_out(uint8_t pin, uint8_t duty) override;

 private:
  Ads1115 adc_;
  Bno055 imu_;
};
