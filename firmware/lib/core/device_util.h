// Small helpers shared by the device core's files (device*.cpp); not part of its interface.
#pragma once
#include <stdint.h>

namespace dev {

// Saturating counters: a health counter stops at its maximum instead of wrapping.
uint16_t sat_add16(uint16_t a, uint16_t b);  // out of line (device.cpp): -36 B of flash
inline uint32_t sat_inc32(uint32_t a) { return a == 0xFFFFFFFFUL ? a : a + 1; }

// Field indices named by NAK.detail for OUT_OF_RANGE (position in the catalogue's field list).
constexpr int16_t kFieldSetpoint = 0, kFieldPumpMask = 1, kFieldValveMask = 2, kFieldSession = 3;

}  // namespace dev
