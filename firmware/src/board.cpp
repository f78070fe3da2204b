#include "board.h"

#include <Arduino.h>
#include <avr/eeprom.h>
#include <avr/wdt.h>

#include "gpio.h"
#include "idle.h"
#include "pins.h"
#include "stack_paint.h"
#include "twi.h"
#include "uart.h"

Board::Board() : adc_(pins::kAds1115Addr), imu_(pins::kBno055Addr) {}

void Board::outputs_safe() {
  for (uint8_t i = 0; i < 3; ++i) {
    gpio::write(pins::pump(i), false);
    gpio::output(pins::pump(i));
    gpio::write(pins::valve(i), false);  // vented
    gpio::output(pins::valve(i));
    gpio::pwm(pins::regulator(i), 0);
  }
}

void Board::begin() {
  uart::begin(pins::kBaud);
  twi::begin(pins::kI2cHz);
  adc_.begin();
  imu_.begin();
}

uint32_t Board::micros() { return ::micros(); }
uint32_t Board::millis() { return ::millis(); }

void Board::apply_outputs(const dev::Outputs& out) {
  for (uint8_t i = 0; i < 3; ++i) {
    // duty = setpoint / -80 kPa * 255, rounded; setpoints are already limited to <= 0.
    int32_t sp = -(int32_t)out.setpoint_dkpa[i];
    if (sp < 0) sp = 0;
    if (sp > 800) sp = 800;
    gpio::pwm(pins::regulator(i), (uint8_t)((sp * 255 + 400) / 800));
    gpio::write(pins::pump(i), (out.pump_mask >> i) & 1);
    gpio::write(pins::valve(i), (out.valve_mask >> i) & 1);
  }
}

bool Board::adc_start(uint8_t ch) { return adc_.start(ch); }
bool Board::adc_finish(int16_t* counts) { return adc_.finish(counts); }
void Board::adc_configure(uint8_t pga_code, uint8_t rate_code) { adc_.configure(pga_code, rate_code); }
bool Board::imu_read(int16_t euler_16[3], uint8_t* sys_cal) { return imu_.read(euler_16, sys_cal); }
bool Board::adc_present() { return adc_.present(); }
bool Board::imu_present() { return imu_.present(); }

int16_t Board::serial_read() { return uart::read(); }
void Board::serial_write(const uint8_t* data, uint8_t n) { uart::write(data, n); }
uint8_t Board::serial_tx_free() { return uart::tx_free(); }

uint8_t Board::eeprom_read(uint16_t addr) { return eeprom_read_byte((const uint8_t*)addr); }
void Board::eeprom_write(uint16_t addr, uint8_t value) {
  idle::run();  // ~3.4 ms per byte: feed the AVR watchdog, keep the link watchdog running
  eeprom_update_byte((uint8_t*)addr, value);
}

void Board::request_reset() {
  uart::flush();  // the ACK leaves before the reset
  outputs_safe();
  wdt_enable(WDTO_15MS);
  for (;;) {
  }
}

uint16_t Board::free_stack() { return stack_paint::untouched_bytes(); }
uint8_t Board::reset_cause() { return stack_paint::reset_cause(); }
void Board::analog_out(uint8_t pin, uint8_t duty) { gpio::pwm(pin, duty); }
