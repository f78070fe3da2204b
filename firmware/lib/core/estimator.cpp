#include "estimator.h"

#include <string.h>

#define ALWAYS_INLINE static inline __attribute__((always_inline))

namespace est {
namespace {

using blob::kStateMax;
using blob::kStateMin;

// Little-endian fields of the blob (memcpy on little-endian targets: no shift loops on the AVR).
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
ALWAYS_INLINE int16_t le16(const uint8_t* p) { int16_t v; memcpy(&v, p, 2); return v; }
ALWAYS_INLINE int32_t le32(const uint8_t* p) { int32_t v; memcpy(&v, p, 4); return v; }
#else
ALWAYS_INLINE int16_t le16(const uint8_t* p) { return int16_t(uint16_t(p[0]) | uint16_t(p[1]) << 8); }
ALWAYS_INLINE int32_t le32(const uint8_t* p) {
  return int32_t(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
}
#endif

// ---------------------------------------------------------------------------------------------
// Arithmetic primitives. Each has a portable C++ definition (the reference the host tests run,
// identical to porosense.quant.fixed) and, on the AVR, an equivalent with the hardware
// multiplier in inline assembly: gcc 5.4 would otherwise call libgcc for 32- and 64-bit
// products and loop bit by bit for variable shifts. tests/quant/avr/primitives.cpp checks every
// AVR version against the portable one in simavr.

// floor(v / 2^s), 0 <= s <= 31.
ALWAYS_INLINE int32_t asr_portable(int32_t v, uint8_t s) { return v >> s; }
// acc + a * b (callers bound the sum to int32).
ALWAYS_INLINE int32_t mac_portable(int32_t acc, int16_t a, int16_t b) { return acc + int32_t(a) * b; }
// floor(b * x / 2^16) for a 32-bit coefficient b.
ALWAYS_INLINE int32_t mul_wide_portable(int32_t b, int16_t x) { return int32_t((int64_t(b) * x) >> 16); }
// round(p * k / 2^n), ties up, 16 <= n <= 47, |p| <= 2^30 (the result fits an int32).
ALWAYS_INLINE int32_t mul_round_portable(int32_t p, int16_t k, uint8_t n) {
  return int32_t(((int64_t(p) * k >> (n - 1)) + 1) >> 1);
}
// s * |d| for a 16-bit magnitude d (|result| < 2^31).
ALWAYS_INLINE int32_t mul_su_portable(int16_t s, uint16_t d) { return int32_t(s) * int32_t(d); }
// floor(y / 2^13) of a state |y| <= 2^28.
ALWAYS_INLINE int16_t q13_portable(int32_t y) { return int16_t(y >> 13); }

#if defined(__AVR__)

// Shared (not inlined) so that the four call sites cost one copy of the shift code: byte moves
// for 16 and 8, then at most 7 single-bit steps.
__attribute__((noinline)) int32_t asr(int32_t v, uint8_t s) {
  asm("sbrs %[s], 4"          "\n\t"
      "rjmp 1f"               "\n\t"
      "movw %A[v], %C[v]"     "\n\t"
      "clr %C[v]"             "\n\t"
      "sbrc %B[v], 7"         "\n\t"
      "com %C[v]"             "\n\t"
      "mov %D[v], %C[v]"      "\n"
      "1:"                    "\n\t"
      "sbrs %[s], 3"          "\n\t"
      "rjmp 2f"               "\n\t"
      "mov %A[v], %B[v]"      "\n\t"
      "mov %B[v], %C[v]"      "\n\t"
      "mov %C[v], %D[v]"      "\n\t"
      "lsl %D[v]"             "\n\t"
      "sbc %D[v], %D[v]"      "\n"
      "2:"                    "\n\t"
      "andi %[s], 7"          "\n\t"
      "breq 4f"               "\n"
      "3:"                    "\n\t"
      "asr %D[v]"             "\n\t"
      "ror %C[v]"             "\n\t"
      "ror %B[v]"             "\n\t"
      "ror %A[v]"             "\n\t"
      "dec %[s]"              "\n\t"
      "brne 3b"               "\n"
      "4:"
      : [v] "+r"(v), [s] "+d"(s));
  return v;
}

// acc + a * b with four hardware multiplies (Atmel AVR201 signed 16x16).
ALWAYS_INLINE int32_t mac(int32_t acc, int16_t a, int16_t b) {
  uint8_t z;
  asm("clr %[z]"              "\n\t"
      "muls %B[a], %B[b]"     "\n\t"
      "add %C[acc], r0"       "\n\t"
      "adc %D[acc], r1"       "\n\t"
      "mul %A[a], %A[b]"      "\n\t"
      "add %A[acc], r0"       "\n\t"
      "adc %B[acc], r1"       "\n\t"
      "adc %C[acc], %[z]"     "\n\t"
      "adc %D[acc], %[z]"     "\n\t"
      "mulsu %B[a], %A[b]"    "\n\t"
      "sbc %D[acc], %[z]"     "\n\t"
      "add %B[acc], r0"       "\n\t"
      "adc %C[acc], r1"       "\n\t"
      "adc %D[acc], %[z]"     "\n\t"
      "mulsu %B[b], %A[a]"    "\n\t"
      "sbc %D[acc], %[z]"     "\n\t"
      "add %B[acc], r0"       "\n\t"
      "adc %C[acc], r1"       "\n\t"
      "adc %D[acc], %[z]"     "\n\t"
      "clr __zero_reg__"
      : [acc] "+r"(acc), [z] "=&r"(z)
      : [a] "a"(a), [b] "a"(b));
  return acc;
}

// The 48-bit product p * k (signed 32 x signed 16, eight hardware multiplies) as
// hi = floor(p * k / 2^16) and g = bits 8..15 (the rounding bit is its top bit); bits 0..7
// are never needed, nothing is added to them.
ALWAYS_INLINE int32_t mul48_hi(int32_t p, int16_t k, uint8_t* guard) {
  int32_t hi;
  uint8_t g, z;
  asm("clr %[z]"              "\n\t"
      "mul %A[p], %A[k]"      "\n\t"   // bytes 0-1
      "mov %[g], r1"          "\n\t"
      "mul %C[p], %A[k]"      "\n\t"   // bytes 2-3
      "movw %A[h], r0"        "\n\t"
      "muls %D[p], %B[k]"     "\n\t"   // bytes 4-5, signed
      "movw %C[h], r0"        "\n\t"
      "mul %B[p], %A[k]"      "\n\t"   // bytes 1-2
      "add %[g], r0"          "\n\t"
      "adc %A[h], r1"         "\n\t"
      "adc %B[h], %[z]"       "\n\t"
      "adc %C[h], %[z]"       "\n\t"
      "adc %D[h], %[z]"       "\n\t"
      "mulsu %D[p], %A[k]"    "\n\t"   // bytes 3-4, signed: C = sign, extended by sbc
      "sbc %D[h], %[z]"       "\n\t"
      "add %B[h], r0"         "\n\t"
      "adc %C[h], r1"         "\n\t"
      "adc %D[h], %[z]"       "\n\t"
      "mulsu %B[k], %A[p]"    "\n\t"   // bytes 1-2, signed
      "sbc %B[h], %[z]"       "\n\t"
      "sbc %C[h], %[z]"       "\n\t"
      "sbc %D[h], %[z]"       "\n\t"
      "add %[g], r0"          "\n\t"
      "adc %A[h], r1"         "\n\t"
      "adc %B[h], %[z]"       "\n\t"
      "adc %C[h], %[z]"       "\n\t"
      "adc %D[h], %[z]"       "\n\t"
      "mulsu %B[k], %B[p]"    "\n\t"   // bytes 2-3, signed
      "sbc %C[h], %[z]"       "\n\t"
      "sbc %D[h], %[z]"       "\n\t"
      "add %A[h], r0"         "\n\t"
      "adc %B[h], r1"         "\n\t"
      "adc %C[h], %[z]"       "\n\t"
      "adc %D[h], %[z]"       "\n\t"
      "mulsu %B[k], %C[p]"    "\n\t"   // bytes 3-4, signed
      "sbc %D[h], %[z]"       "\n\t"
      "add %B[h], r0"         "\n\t"
      "adc %C[h], r1"         "\n\t"
      "adc %D[h], %[z]"       "\n\t"
      "clr __zero_reg__"
      : [h] "=&r"(hi), [g] "=&r"(g), [z] "=&r"(z)
      : [p] "a"(p), [k] "a"(k));
  *guard = g;
  return hi;
}

ALWAYS_INLINE int32_t mul_wide(int32_t b, int16_t x) {
  uint8_t g;
  return mul48_hi(b, x, &g);
}

ALWAYS_INLINE int32_t mul_round(int32_t p, int16_t k, uint8_t n) {
  uint8_t g;
  int32_t hi = mul48_hi(p, k, &g);  // floor(p k / 2^16)
  if (n == 16) return hi + (g >> 7);
  return (asr(hi, uint8_t(n - 17)) + 1) >> 1;
}

// Signed s times unsigned d.
ALWAYS_INLINE int32_t mul_su(int16_t s, uint16_t d) {
  int32_t r;
  uint8_t z;
  asm("clr %[z]"              "\n\t"
      "mulsu %B[s], %B[d]"    "\n\t"
      "movw %C[r], r0"        "\n\t"
      "mul %A[s], %A[d]"      "\n\t"
      "movw %A[r], r0"        "\n\t"
      "mulsu %B[s], %A[d]"    "\n\t"
      "sbc %D[r], %[z]"       "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "mul %B[d], %A[s]"      "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "clr __zero_reg__"
      : [r] "=&r"(r), [z] "=&r"(z)
      : [s] "a"(s), [d] "a"(d));
  return r;
}

// floor(y / 2^13): bytes 1..3 shifted left by 3, the top two bytes kept.
ALWAYS_INLINE int16_t q13(int32_t y) {
  int16_t r;
  uint8_t t;
  asm("mov %[t], %B[y]"       "\n\t"
      "mov %A[r], %C[y]"      "\n\t"
      "mov %B[r], %D[y]"      "\n\t"
      "lsl %[t]"              "\n\t"
      "rol %A[r]"             "\n\t"
      "rol %B[r]"             "\n\t"
      "lsl %[t]"              "\n\t"
      "rol %A[r]"             "\n\t"
      "rol %B[r]"             "\n\t"
      "lsl %[t]"              "\n\t"
      "rol %A[r]"             "\n\t"
      "rol %B[r]"
      : [r] "=&r"(r), [t] "=&r"(t)
      : [y] "r"(y));
  return r;
}

#else

ALWAYS_INLINE int32_t asr(int32_t v, uint8_t s) { return asr_portable(v, s); }
ALWAYS_INLINE int32_t mac(int32_t acc, int16_t a, int16_t b) { return mac_portable(acc, a, b); }
ALWAYS_INLINE int32_t mul_wide(int32_t b, int16_t x) { return mul_wide_portable(b, x); }
ALWAYS_INLINE int32_t mul_round(int32_t p, int16_t k, uint8_t n) { return mul_round_portable(p, k, n); }
ALWAYS_INLINE int32_t mul_su(int16_t s, uint16_t d) { return mul_su_portable(s, d); }
ALWAYS_INLINE int16_t q13(int32_t y) { return q13_portable(y); }

#endif

// round(v / 2^s), ties up: floor(v / 2^(s-1)) + 1, halved (no overflow of v + 2^(s-1)).
ALWAYS_INLINE int32_t round_shift(int32_t v, uint8_t s) {
  if (s == 0) return v;
  return (asr(v, uint8_t(s - 1)) + 1) >> 1;
}

ALWAYS_INLINE int16_t sat16(int32_t v, uint8_t* flags) {
  if (v > 32767) { *flags |= Estimator::kSaturated; return 32767; }
  if (v < -32768) { *flags |= Estimator::kSaturated; return -32768; }
  return int16_t(v);
}

// Clamp of a state to [-2^28, 2^28 - 1]: in range exactly when bits 28..31 agree, i.e. when
// the top byte plus 0x10 is below 0x20 (one byte test instead of two 32-bit compares).
ALWAYS_INLINE int32_t clamp_state(int32_t v, uint8_t* flags) {
  uint8_t top = uint8_t(uint32_t(v) >> 24);
  if (uint8_t(top + 0x10) & 0xE0) {
    *flags |= Estimator::kSaturated;
    return (top & 0x80) ? kStateMin : kStateMax;
  }
  return v;
}

// One second-order section (record `rec`, MODEL_FORMAT.md). x: inputs at k, k-1, k-2 on entry,
// this section's outputs at k, k-1, k-2 on return (the next section's inputs: the cascade
// shares them instead of storing them twice). ys: states y[k-1], y[k-2] in Q13, updated.
// Returns y[k]. Not inlined: one copy serves every section of every cascade.
ALWAYS_INLINE int32_t run_section(const uint8_t* rec, int16_t x[3], int32_t ys[2],
                                uint8_t* flags) {
  const uint8_t fl = rec[0];
  const uint8_t* c = rec + blob::kSecFixedLen;
  // Numerator in Q13 of the output: exact int32 for 16-bit b, floored partial products for
  // 32-bit b. Every term is bounded by validate() (|W| <= 2^29, |base| <= 3 * 2^28,
  // |P1| <= 2^28 + 1, |P2| <= 2^27 + 1), so the int32 sums cannot overflow.
  int32_t w = 0;
  if (fl & blob::kSecWide) {
    for (uint8_t i = 0; i < 3; ++i, c += 4) w += mul_wide(le32(c), x[i]);
  } else {
    for (uint8_t i = 0; i < 3; ++i, c += 2) w = mac(w, x[i], le16(c));
  }
  const int32_t y1 = ys[0], y2 = ys[1];
  int32_t acc = round_shift(w, rec[1]);
  int32_t p1 = y1;
  if (fl & blob::kSecDelta) {
    // Delta form: y = 2y1 - y2 - alpha1 (y1 - y2) - alpha0 y2 (poles near z = 1).
    acc += 2 * y1 - y2;
    p1 = y1 - y2;
  } else {
    // Direct form with integer base weights m1, m2 and residues |k| <= 1/2.
    switch ((fl >> 2) & 7) {
      case 0: acc -= 2 * y1; break;
      case 1: acc -= y1; break;
      case 3: acc += y1; break;
      case 4: acc += 2 * y1; break;
      default: break;
    }
    switch ((fl >> 5) & 3) {
      case 0: acc -= y2; break;
      case 2: acc += y2; break;
      default: break;
    }
  }
  acc += mul_round(p1, le16(c), rec[2]);
  acc += mul_round(y2, le16(c + 2), rec[3]);
  const int32_t y = clamp_state(acc, flags);
  ys[1] = y1;
  ys[0] = y;
  x[0] = q13(y);
  x[1] = q13(y1);
  x[2] = q13(y2);
  return y;
}

}  // namespace

Estimator::Estimator() : blob_(0), length_(0), n_in_(0), n_out_(0), head_(0), flags_(0) {
  memset(&header_, 0, sizeof(header_));
  reset();
}

bool Estimator::load(const BlobReader& blob, uint16_t length, uint16_t max_length) {
  unload();
  if (!blob::validate(blob, length, max_length)) return false;
  blob::read_header(blob, length, &header_, max_length);
  blob_ = &blob;
  length_ = length;
  n_in_ = header_.n_inputs;
  n_out_ = header_.n_outputs;
  reset();
  return true;
}

void Estimator::unload() {
  blob_ = 0;
  length_ = 0;
  n_in_ = n_out_ = 0;
  memset(&header_, 0, sizeof(header_));
}

void Estimator::reset() {
  memset(delay_, 0, sizeof(delay_));
  memset(xhist_, 0, sizeof(xhist_));
  memset(ystate_, 0, sizeof(ystate_));
  head_ = 0;
}

// Table with n breakpoints whose x[] starts at `xs` (after the count byte).
int16_t Estimator::pwl(uint16_t xs, uint8_t n, int16_t x) {
  // Segment k: the last breakpoint <= x among 0..n-2 (segment 0 also left of x[0]); the
  // search keeps the x[k] it read, so only x[0] may need a read of its own.
  uint8_t lo = 0, hi = uint8_t(n - 2);
  uint8_t b[3];
  int16_t xk = 0;
  while (lo < hi) {
    uint8_t mid = uint8_t((lo + hi + 1) >> 1);
    blob_->read(uint16_t(xs + 2 * mid), b, 2);
    int16_t xm = le16(b);
    if (xm <= x) { lo = mid; xk = xm; } else hi = uint8_t(mid - 1);
  }
  if (lo == 0) { blob_->read(xs, b, 2); xk = le16(b); }
  blob_->read(uint16_t(xs + 2 * n + 2 * lo), b, 2);
  int16_t yk = le16(b);
  blob_->read(uint16_t(xs + 4 * n + 3 * lo), b, 3);
  int16_t slope = le16(b);
  // |x - x[k]| <= 65535 and |slope| <= 32768, so the product fits an int32: sign and magnitude.
  int32_t dx = int32_t(x) - xk;
  int32_t p = dx >= 0 ? mul_su(slope, uint16_t(dx)) : -mul_su(slope, uint16_t(-dx));
  return sat16(int32_t(yk) + round_shift(p, b[2]), &flags_);
}

__attribute__((noinline)) int32_t Estimator::cascade(uint16_t* off, uint8_t n, int16_t x) {
  int16_t* xh = xhist_[cascade_++];
  int16_t xs[3] = {x, xh[0], xh[1]};
  xh[1] = xh[0];
  xh[0] = x;
  int32_t* ys = ystate_[section_];
  section_ = uint8_t(section_ + n);
  int32_t y = 0;
  uint8_t rec[blob::kSecLen32];
  uint16_t at = *off;
  for (uint8_t s = 0; s < n; ++s, ys += 2) {
    // One read covers a 16-bit section; a wide one needs its last 6 bytes as well.
    blob_->read(at, rec, blob::kSecLen16);
    at = uint16_t(at + blob::kSecLen16);
    if (rec[0] & blob::kSecWide) {
      blob_->read(at, rec + blob::kSecLen16, uint8_t(blob::kSecLen32 - blob::kSecLen16));
      at = uint16_t(at + (blob::kSecLen32 - blob::kSecLen16));
    }
    y = run_section(rec, xs, ys, &flags_);
  }
  *off = at;
  return y;
}

uint8_t Estimator::step(const int16_t dr_centi[3], int16_t estimate[3]) {
  estimate[0] = estimate[1] = estimate[2] = 0;
  if (!blob_) return 0;
  flags_ = 0;
  head_ = uint8_t((head_ + 1) & (kDelayLen - 1));
  for (uint8_t i = 0; i < n_in_; ++i) delay_[i][head_] = dr_centi[i];
  cascade_ = 0;
  section_ = 0;
  uint16_t off = blob::kHeaderLen;
  // A branch record and the byte after it (a table's breakpoint count) in one read.
  uint8_t rec[blob::kBranchRecLen + 1];
  for (uint8_t j = 0; j < n_out_; ++j) {
    blob_->read(off, rec, blob::kOutputRecLen);
    off = uint16_t(off + blob::kOutputRecLen);
    uint8_t nb = rec[0], ofl = rec[1];
    int16_t out_offset = le16(rec + 2);
    int32_t sum = 0;  // Q13, |.| <= 3 * 2^28
    for (uint8_t b = 0; b < nb; ++b) {
      blob_->read(off, rec, blob::kBranchRecLen + 1);
      off = uint16_t(off + blob::kBranchRecLen);
      int16_t u = delay_[rec[0]][(head_ - rec[1]) & (kDelayLen - 1)];
      int16_t x = sat16(int32_t(u) - le16(rec + 2), &flags_);
      uint8_t ns = rec[5];
      if (rec[4] & blob::kBranchHasF) {
        uint8_t n = rec[6];
        x = pwl(uint16_t(off + 1), n, x);
        off = uint16_t(off + blob::pwl_len(n));
      }
      sum += cascade(&off, ns, x);
    }
    int16_t v = sat16(sum >> blob::kStateFrac, &flags_);
    if (ofl & blob::kOutHasG) {
      uint8_t n;
      blob_->read(off, &n, 1);
      v = pwl(uint16_t(off + 1), n, v);
      off = uint16_t(off + blob::pwl_len(n));
    }
    if (ofl & blob::kOutHasH2) {
      uint8_t ns;
      blob_->read(off, &ns, 1);
      off = uint16_t(off + 1);
      v = q13(cascade(&off, ns, v));
    }
    estimate[j] = sat16(int32_t(v) + out_offset, &flags_);
  }
  return flags_;
}

}  // namespace est
