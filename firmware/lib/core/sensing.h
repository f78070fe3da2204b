// Sensor arithmetic: ADS1115 counts -> divider voltage -> sensor resistance -> dR.
// Divider per channel: 5 V -> 1 kOhm bias -> ADC node -> sensor -> GND, so
// R = 1000 V / (5 - V) and dR = (R - R0) / R0, reported in 0.01 % (int16, saturated).
#pragma once
#include <stdint.h>

namespace dev {

constexpr float kSupplyV = 5.0f;
constexpr float kBiasOhm = 1000.0f;
constexpr int32_t kNominalR0Mohm = 1000000;  // 1 kOhm, the documented default

// Volts per count of the ADS1115 for a PGA code (0 = +-6.144 V ... 5 = +-0.256 V).
float adc_volts_per_count(uint8_t pga_code);

// Sensor resistance in ohm for a divider voltage; very large when V reaches the supply.
float divider_resistance(float volts);

// dR = (R - R0) / R0 in 0.01 %, rounded to nearest and saturated to int16.
int16_t dr_centi(float r_ohm, float r0_ohm);

// The whole chain for one channel.
int16_t counts_to_dr_centi(int16_t counts, uint8_t pga_code, float r0_ohm);

// R in ohm from a mean count (used by R0 calibration).
float counts_to_ohm(float mean_counts, uint8_t pga_code);

// True when a count sits at the converter's full-scale limit.
inline bool adc_clipped(int16_t counts) { return counts >= 32767 || counts <= -32768; }

}  // namespace dev
