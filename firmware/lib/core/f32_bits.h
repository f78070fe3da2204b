// Integer helpers that keep the soft-float library off the board: a 32 x 32 / 32 division
// with a 64-bit intermediate, and IEEE-754 single-precision values (as the protocol and the
// model header carry them) to and from scaled integers.
#pragma once
#include <stdint.h>

namespace dev {

// floor(x * m / d) and its remainder (d > 0); 0xFFFFFFFF (remainder 0) when the quotient
// does not fit 32 bits.
uint32_t muldiv(uint32_t x, uint32_t m, uint32_t d, uint32_t* rem);

// round(x * m / d), halves up; 0xFFFFFFFF when beyond 32 bits.
uint32_t muldiv_round(uint32_t x, uint32_t m, uint32_t d);

// round(value(bits) * factor), halves away from zero, clamped to [-limit, limit] (limit <
// 2^31). NaN gives 0 and false; a clamped result (infinities too) gives false.
bool f32_scaled(uint32_t bits, int32_t factor, int32_t limit, int32_t* out);

// The float32 nearest num / den (halves up) for 1 <= num / den < 2^24.
uint32_t f32_from_ratio(uint32_t num, uint32_t den);

}  // namespace dev
