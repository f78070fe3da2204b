#include "f32_bits.h"

#include <string.h>

namespace dev {

// Out of line: one copy serves every caller.
__attribute__((noinline)) uint32_t muldiv(uint32_t x, uint32_t m, uint32_t d, uint32_t* rem) {
  const uint64_t p = (uint64_t)x * m;  // one widening multiply
  uint32_t lo, hi;                     // halves by copy, not by a 64-bit shift (a library call on the AVR)
  memcpy(&lo, &p, 4);
  memcpy(&hi, reinterpret_cast<const uint8_t*>(&p) + 4, 4);
  *rem = 0;
  if (hi >= d) return 0xFFFFFFFFUL;
  // Restoring division of hi:lo by d, one quotient bit per pass (no 64-bit division code).
  uint32_t q = 0;
  for (uint8_t i = 0; i < 32; ++i) {
    const bool carry = (hi >> 31) != 0;
    hi = hi << 1 | lo >> 31;
    lo <<= 1;
    q <<= 1;
    if (carry || hi >= d) hi -= d, q |= 1;
  }
  *rem = hi;
  return q;
}

uint32_t muldiv_round(uint32_t x, uint32_t m, uint32_t d) {
  uint32_t rem;
  const uint32_t q = muldiv(x, m, d, &rem);
  return q + (q != 0xFFFFFFFFUL && rem >= d - rem);
}

bool f32_scaled(uint32_t bits, int32_t factor, int32_t limit, int32_t* out) {
  const uint8_t e = (uint8_t)(bits >> 23);
  const bool neg = ((bits >> 31) != 0) != (factor < 0);
  const uint32_t f = (uint32_t)(factor < 0 ? -factor : factor);
  // |value| = m 2^-k, m < 2^24; zero and subnormals (below 1.2e-38) count as 0.
  uint32_t m = e ? (bits & 0x7FFFFFUL) | 0x800000UL : 0;
  int16_t k = (int16_t)(150 - e);
  uint32_t mag = 0, rem;
  bool ok = !(e == 0xFF && (bits & 0x7FFFFFUL));  // NaN: 0
  if (ok) {
    if (k >= 56) m = 0;  // m |factor| < 2^55: below half a unit
    if (k <= 0) {        // whole: m |factor| 2^-k, doubled until past the limit
      mag = muldiv(m, f, 1, &rem);
      for (; k < 0 && mag <= (uint32_t)limit; ++k) mag <<= 1;
    } else {
      // Floor in units of 2^-(k-1) (at most 2^-31 a step, then shifted), then round half up:
      // the halfway points of 2^-k are whole in the finer unit, so the floor loses nothing.
      const uint8_t s = (uint8_t)(k > 32 ? 31 : k - 1);
      mag = muldiv(m, f, 1UL << s, &rem);
      for (uint8_t i = (uint8_t)(k - 1 - s); i && mag; --i) mag >>= 1;
      if (mag != 0xFFFFFFFFUL) mag = (mag + 1) >> 1;
    }
    if (mag > (uint32_t)limit) mag = (uint32_t)limit, ok = false;
  }
  *out = neg ? -(int32_t)mag : (int32_t)mag;
  return ok;
}

uint32_t f32_from_ratio(uint32_t num, uint32_t den) {
  // Mantissa m = num 2^s / den in [2^23, 2^24): the largest s that keeps it below 2^24.
  uint8_t s = 24;
  uint32_t m;
  do m = muldiv_round(num, 1UL << --s, den);
  while (m >> 24);
  return (uint32_t)(127 + 23 - s) << 23 | (m & 0x7FFFFFUL);
}

}  // namespace dev
