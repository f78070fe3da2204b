#include "bno055.h"

#include <Arduino.h>

#include "idle.h"
#include "twi.h"

namespace {
constexpr uint8_t kRegChipId = 0x00;
constexpr uint8_t kChipId = 0xA0;
constexpr uint8_t kRegEulerH = 0x1A;  // heading, roll, pitch: int16 LE each
constexpr uint8_t kRegCalibStat = 0x35;
constexpr uint8_t kRegUnitSel = 0x3B;
constexpr uint8_t kRegOprMode = 0x3D;
constexpr uint8_t kRegPwrMode = 0x3E;
constexpr uint8_t kRegPageId = 0x07;
constexpr uint8_t kModeConfig = 0x00;
constexpr uint8_t kModeNdof = 0x0C;
constexpr uint16_t kToConfigMs = 19;
constexpr uint16_t kFromConfigMs = 7;

void wait_ms(uint16_t ms) {
  const uint32_t t0 = millis();
  while ((uint32_t)(millis() - t0) < ms) idle::run();
}
}  // namespace

bool Bno055::write8(uint8_t reg, uint8_t value) { return twi::write_reg(addr_, reg, &value, 1); }

bool Bno055::begin(uint16_t boot_ms) {
  present_ = false;
  const uint32_t t0 = millis();
  uint8_t id = 0;
  for (;;) {
    if (twi::read_reg(addr_, kRegChipId, &id, 1) && id == kChipId) break;
    if ((uint32_t)(millis() - t0) > boot_ms) return false;
    wait_ms(10);
  }
  if (!write8(kRegPageId, 0)) return false;
  if (!write8(kRegOprMode, kModeConfig)) return false;
  wait_ms(kToConfigMs);
  if (!write8(kRegPwrMode, 0x00)) return false;  // normal power
  if (!write8(kRegUnitSel, 0x00)) return false;  // Windows orientation, degrees (16 LSB/deg)
  if (!write8(kRegOprMode, kModeNdof)) return false;
  wait_ms(kFromConfigMs);
  present_ = true;
  return true;
}

bool Bno055::read(int16_t euler_16[3], uint8_t* sys_cal) {
  uint8_t b[6];
  uint8_t cal = 0;
  if (!twi::read_reg(addr_, kRegEulerH, b, 6) || !twi::read_reg(addr_, kRegCalibStat, &cal, 1)) {
    present_ = false;
    return false;
  }
  for (uint8_t i = 0; i < 3; ++i) euler_16[i] = (int16_t)(b[2 * i] | (uint16_t)(b[2 * i + 1] << 8));
  *sys_cal = (uint8_t)(cal >> 6);
  present_ = true;
  return true;
}
