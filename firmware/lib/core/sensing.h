// Sensor arithmetic: ADS1115 counts -> divider voltage -> sensor resistance -> dR, in integers.
// Divider per channel: 5 V -> 1 kOhm bias -> ADC node -> sensor -> GND, so
// R = 1000 V / (5 - V) and dR = (R - R0) / R0, reported in 0.01 % (int16, saturated).
// With V = counts * FS / 32768 (FS the PGA's full scale): R = 1000 ohm * a / (b - a), with
// a = counts and b = 40000 * 4.096 V / FS (a = 3 counts and b = 80000 at FS = 6.144 V).
#pragma once
#include <stdint.h>

namespace dev {

constexpr int32_t kNominalR0Mohm = 1000000;  // 1 kOhm, the documented default

// The divider's terms for a PGA code (0 = +-6.144 V ... 5 = +-0.256 V; above 5 as 5):
// R = 1000 ohm * a / (b - a) with a = counts * divider_a(code) and b = divider_b(code).
inline uint8_t divider_a(uint8_t pga_code) { return pga_code == 0 ? 3 : 1; }
uint32_t divider_b(uint8_t pga_code);

// dR = (R - R0) / R0 in 0.01 %, rounded half away from zero and saturated to int16; R of one
// conversion, R0 in milliohm (<= 1e8: every product fits 64 bits). 0 when R0 <= 0; -100 % at
// or below 0 V; saturated high at or above the supply (open sensor).
int16_t counts_to_dr_centi(int16_t counts, uint8_t pga_code, int32_t r0_mohm);

// R in milliohm, rounded half up, of the mean of n conversions whose sum is `sum`
// (R0 calibration). 0 at or below 0 V; 0x7FFFFFFF at or above the supply and beyond int32.
int32_t counts_to_mohm(int32_t sum, uint8_t n, uint8_t pga_code);

// True when a count sits at the converter's full-scale limit.
inline bool adc_clipped(int16_t counts) { return counts >= 32767 || counts <= -32768; }

}  // namespace dev
