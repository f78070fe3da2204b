#include "sensing.h"

#include "f32_bits.h"

namespace dev {

namespace {
constexpr int32_t kMaxMohm = 0x7FFFFFFFL;
}  // namespace

uint32_t divider_b(uint8_t pga_code) {
  // FS = 6.144 V at code 0 (3/16000 V per count, so a is 3 counts), else 4.096 V halving
  // per code (1/8000 V per count at code 1): b = 5 V over the volts per unit of a.
  if (pga_code == 0) return 80000UL;
  uint32_t b = 40000UL;
  for (uint8_t i = 1; i < pga_code && i < 5; ++i) b <<= 1;
  return b;
}

// R in milliohm, rounded, for the divider terms a (> 0) and b - a (> 0); kMaxMohm from about
// 4.29 MOhm (then the quotient would not fit 32 bits).
static int32_t divider_mohm(uint32_t a, uint32_t b_minus_a) {
  if (b_minus_a * 4295UL <= a) return kMaxMohm;  // 1e6 / 2^32 < 1 / 4294.9
  const uint32_t r = muldiv_round(a, 1000000UL, b_minus_a);
  return r > (uint32_t)kMaxMohm ? kMaxMohm : (int32_t)r;
}

int16_t counts_to_dr_centi(int16_t counts, uint8_t pga_code, int32_t r0_mohm) {
  if (r0_mohm <= 0) return 0;
  const uint32_t b = divider_b(pga_code);
  const int32_t a = (int32_t)counts * divider_a(pga_code);
  if (a <= 0) return -10000;           // 0 V or below: R = 0
  if ((uint32_t)a >= b) return 32767;  // at or above the supply: open
  const int32_t r = divider_mohm((uint32_t)a, b - (uint32_t)a);
  // dR = 1e4 (R - R0) / R0; R below 5 R0 keeps the quotient within 4e4 (saturated below).
  if (r / 5 >= r0_mohm) return 32767;
  const bool up = r >= r0_mohm;
  const uint32_t q = muldiv_round((uint32_t)(up ? r - r0_mohm : r0_mohm - r), 10000UL, (uint32_t)r0_mohm);
  if (up) return q > 32767 ? 32767 : (int16_t)q;
  return (int16_t) - (int32_t)q;
}

int32_t counts_to_mohm(int32_t sum, uint8_t n, uint8_t pga_code) {
  const int32_t a = sum * divider_a(pga_code);  // |sum| <= 64 * 32768: within int32 times 3
  const uint32_t b = divider_b(pga_code) * n;
  if (a <= 0) return 0;
  if ((uint32_t)a >= b) return kMaxMohm;
  return divider_mohm((uint32_t)a, b - (uint32_t)a);  // R of the mean a / n
}

}  // namespace dev
