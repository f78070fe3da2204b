#include "sensing.h"

namespace dev {

float adc_volts_per_count(uint8_t pga_code) {
  // Full scale 6.144 V at code 0, halving per code from 4.096 V at code 1.
  if (pga_code == 0) return 6.144f / 32768.0f;
  if (pga_code > 5) pga_code = 5;
  float fs = 4.096f;
  for (uint8_t i = 1; i < pga_code; ++i) fs *= 0.5f;
  return fs / 32768.0f;
}

float divider_resistance(float volts) {
  if (volts <= 0.0f) return 0.0f;
  const float headroom = kSupplyV - volts;
  // At or beyond the supply the sensor is open: report a resistance that saturates dR.
  if (headroom <= 1e-6f) return 1e9f;
  return kBiasOhm * volts / headroom;
}

int16_t dr_centi(float r_ohm, float r0_ohm) {
  if (!(r0_ohm > 0.0f)) return 0;
  const float d = (r_ohm - r0_ohm) / r0_ohm * 10000.0f;
  if (d >= 32767.0f) return 32767;
  if (d <= -32768.0f) return -32768;
  return (int16_t)(d >= 0.0f ? d + 0.5f : d - 0.5f);
}

float counts_to_ohm(float mean_counts, uint8_t pga_code) {
  return divider_resistance(mean_counts * adc_volts_per_count(pga_code));
}

int16_t counts_to_dr_centi(int16_t counts, uint8_t pga_code, float r0_ohm) {
  return dr_centi(counts_to_ohm((float)counts, pga_code), r0_ohm);
}

}  // namespace dev
