#include "ads1115.h"

#include <Arduino.h>

#include "idle.h"
#include "twi.h"

namespace {
constexpr uint8_t kRegConversion = 0x00;
constexpr uint8_t kRegConfig = 0x01;
constexpr uint16_t kOs = 0x8000;          // write: start; read: 1 = idle
constexpr uint16_t kModeSingle = 0x0100;
constexpr uint16_t kCompDisable = 0x0003;

uint16_t samples_per_s(uint8_t rate_code) {  // a switch, not a table: tables cost RAM on AVR
  switch (rate_code) {
    case 0: return 8;
    case 1: return 16;
    case 2: return 32;
    case 3: return 64;
    case 4: return 128;
    case 5: return 250;
    case 6: return 475;
    default: return 860;
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

bool Ads1115::read(uint8_t channel, int16_t* counts) {
  const uint16_t mux = (uint16_t)((4u + (channel & 3u)) << 12);  // AINx vs GND
  const uint16_t cfg = kOs | mux | (uint16_t)(pga_ << 9) | kModeSingle |
                       (uint16_t)(rate_ << 5) | kCompDisable;
  const uint8_t w[2] = {(uint8_t)(cfg >> 8), (uint8_t)cfg};
  if (!twi::write_reg(addr_, kRegConfig, w, 2)) {
    present_ = false;
    return false;
  }
  const uint32_t nominal = conversion_us();
  // The internal oscillator is within 10 %: wait 90 % of the nominal time, then poll OS.
  const uint32_t first_poll = nominal - nominal / 10;
  const uint32_t deadline = 2 * nominal + 2000;
  const uint32_t t0 = micros();
  while ((uint32_t)(micros() - t0) < first_poll) idle::run();
  uint8_t b[2];
  for (;;) {
    if (!twi::read_reg(addr_, kRegConfig, b, 2)) {
      present_ = false;
      return false;
    }
    if (b[0] & 0x80) break;  // OS = 1: conversion finished
    if ((uint32_t)(micros() - t0) > deadline) return false;
    idle::run();
  }
  if (!twi::read_reg(addr_, kRegConversion, b, 2)) {
    present_ = false;
    return false;
  }
  present_ = true;
  *counts = (int16_t)((uint16_t)(b[0] << 8) | b[1]);
  return true;
}
