// A small I2C master for the ATmega328P TWI with a deadline on every bus phase.
// The stock Wire library waits forever on a stuck bus or a missing device (and its buffers
// cost ~200 bytes of RAM); here every call returns within a bounded time, and a failed
// transfer resets the peripheral and frees a slave that holds SDA low.
#pragma once
#include <stdint.h>

namespace twi {

constexpr uint16_t kPhaseTimeoutUs = 2000;  // per start/address/byte; BNO055 stretches SCL

void begin(uint32_t scl_hz);
// Write reg, then n bytes. False on NACK or timeout.
bool write_reg(uint8_t addr, uint8_t reg, const uint8_t* data, uint8_t n);
// Write reg, repeated start, read n bytes. False on NACK or timeout.
bool read_reg(uint8_t addr, uint8_t reg, uint8_t* dst, uint8_t n);
// Read n bytes without writing a register pointer first (the device's current pointer).
bool read(uint8_t addr, uint8_t* dst, uint8_t n);
// True when a device acknowledges its address.
bool probe(uint8_t addr);
uint16_t timeouts();  // bus phases that missed their deadline since boot

}  // namespace twi
