#include "ads1115.h"

#include <Arduino.h>

#include "idle.h"
#include "twi.h"

namespace {
constexpr uint8_t kRegConversion = 0x00;
constexpr uint8_t kRegConfig = 0x01;
constexpr uint16_t kOs = 0x8000;  // write: start; read: 1 = idle
constexpr uint16_t kModeSingle = 0x0100;
constexpr uint16_t kCompDisable = 0x0003;

uint16_t samples_per_s(uint8_t rate_code) {  // a switch, not a table: tables cost RAM on AVR
  switch (rate_code) {
    case 0:
      return 8;
    case 1:
      return 16;
    case 2:
      return 32;
    case 3:
      return 64;
    case 4:
      return 128;
    case 5:
      return 250;
    case 6:
      return 475;
    default:
      return 860;
  }
}
}  // namespace

bool Ads1115::begin() {
  uint8_t b[2];
  present_ = twi::read_reg(addr_, kRegConfig, b, 2);
  return present_;
}

void Ads1115::configure(uint8_t pga_code, uint8_t rate_code) {
  pga_ = pga_code > 5 ? 5 : pga_code;
  rate_ = rate_code & 7;
}

uint32_t Ads1115::conversion_us() const { return 1000000UL / samples_per_s(rate_) + 1; }

bool Ads1115::fail() {
  present_ = false;
  return false;
}

bool Ads1115::start(uint8_t channel) {
  const uint16_t mux = (uint16_t)((4u + (channel & 3u)) << 12);  // AINx vs GND
  const uint16_t cfg = kOs | mux | (uint16_t)(pga_ << 9) | kModeSingle | (uint16_t)(rate_ << 5) | kCompDisable;
  const uint8_t w[2] = {(uint8_t)(cfg >> 8), (uint8_t)cfg};
  // Also leaves the register pointer on the config register for the OS polls.
  if (!twi::write_reg(addr_, kRegConfig, w, 2)) return fail();
  t_start_ = micros();
  return true;
}

bool Ads1115::finish(int16_t* counts) {
  const uint32_t nominal = conversion_us();
  const uint32_t deadline = 2 * nominal + 2000;
  while ((uint32_t)(micros() - t_start_) < nominal) idle::run();
  uint8_t b[2];
  for (;;) {
    // The pointer still selects the config register: a bare read returns it.
    if (!twi::read(addr_, b, 2)) return fail();
    if (b[0] & 0x80) break;  // OS = 1: conversion finished
    if ((uint32_t)(micros() - t_start_) > deadline) return false;
    idle::run();
  }
  if (!twi::read_reg(addr_, kRegConversion, b, 2)) return fail();
  present_ = true;
  *counts = (int16_t)((uint16_t)(b[0] << 8) | b[1]);
  return true;
}
