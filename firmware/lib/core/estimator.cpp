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

// Word and byte moves written so that avr-gcc -Os does not turn them into bit-shift loops
// (a union on little-endian targets, plain shifts elsewhere).
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
union Word32 {
  int32_t s;
  uint16_t w[2];
  uint8_t b[4];
};
ALWAYS_INLINE int32_t asr16(int32_t v) { Word32 x; x.s = v; return int32_t(int16_t(x.w[1])); }
ALWAYS_INLINE int32_t asr8(int32_t v) {
  Word32 x, y;
  x.s = v;
  y.b[0] = x.b[1]; y.b[1] = x.b[2]; y.b[2] = x.b[3]; y.b[3] = (x.b[3] & 0x80) ? 0xFF : 0x00;
  return y.s;
}
#else
ALWAYS_INLINE int32_t asr16(int32_t v) { return v >> 16; }
ALWAYS_INLINE int32_t asr8(int32_t v) { return v >> 8; }
#endif

// Arithmetic right shift: word and byte moves first, a bit loop for the rest (< 8).
ALWAYS_INLINE int32_t asr32(int32_t v, uint8_t s) {
  if (s >= 16) { v = asr16(v); s = uint8_t(s - 16); }
  if (s >= 8) { v = asr8(v); s = uint8_t(s - 8); }
  while (s) { v >>= 1; --s; }
  return v;
}

// round(v / 2^s), ties up; the form avoids overflow of v + 2^(s-1).
ALWAYS_INLINE int32_t round_shift(int32_t v, uint8_t s) {
  if (s == 0) return v;
  return (asr32(v, uint8_t(s - 1)) + 1) >> 1;
}

// 16x16->32 products. On the AVR in inline assembly with the hardware multiplier (Atmel
// AVR201: about 20 cycles instead of a libgcc call); elsewhere plain C.
#if defined(__AVR__)
ALWAYS_INLINE int32_t mul_ss(int16_t a, int16_t b) {
  int32_t r;
  uint8_t z;
  asm("clr %[z]"              "\n\t"
      "muls %B[a], %B[b]"     "\n\t"
      "movw %C[r], r0"        "\n\t"
      "mul %A[a], %A[b]"      "\n\t"
      "movw %A[r], r0"        "\n\t"
      "mulsu %B[a], %A[b]"    "\n\t"
      "sbc %D[r], %[z]"       "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "mulsu %B[b], %A[a]"    "\n\t"
      "sbc %D[r], %[z]"       "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "clr __zero_reg__"
      : [r] "=&r"(r), [z] "=&r"(z)
      : [a] "a"(a), [b] "a"(b));
  return r;
}
// Signed a times unsigned b.
ALWAYS_INLINE int32_t mul_su(int16_t a, uint16_t b) {
  int32_t r;
  uint8_t z;
  asm("clr %[z]"              "\n\t"
      "mulsu %B[a], %B[b]"    "\n\t"
      "movw %C[r], r0"        "\n\t"
      "mul %A[a], %A[b]"      "\n\t"
      "movw %A[r], r0"        "\n\t"
      "mulsu %B[a], %A[b]"    "\n\t"
      "sbc %D[r], %[z]"       "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "mul %B[b], %A[a]"      "\n\t"
      "add %B[r], r0"         "\n\t"
      "adc %C[r], r1"         "\n\t"
      "adc %D[r], %[z]"       "\n\t"
      "clr __zero_reg__"
      : [r] "=&r"(r), [z] "=&r"(z)
      : [a] "a"(a), [b] "a"(b));
  return r;
}
#else
ALWAYS_INLINE int32_t mul_ss(int16_t a, int16_t b) { return int32_t(a) * int32_t(b); }
ALWAYS_INLINE int32_t mul_su(int16_t a, uint16_t b) { return int32_t(a) * int32_t(b); }
#endif

// floor(y / 2^13) for a state |y| <= 2^28, as the high word of 8y (no 13-step shift loop).
ALWAYS_INLINE int16_t q13_to_int16(int32_t y) { return int16_t(asr16(int32_t(uint32_t(y) << 3))); }

// round(p * k / 2^n), ties up, for |p| <= 2^30 and 16 <= n <= 47, with two 16x16->32
// products: p*k = ph*k*2^16 + pl*k with pl unsigned.
ALWAYS_INLINE int32_t mul_round(int32_t p, int16_t k, uint8_t n) {
  int32_t hi = mul_ss(int16_t(asr16(p)), k);
  int32_t lo = mul_su(k, uint16_t(uint32_t(p) & 0xFFFFu));
  if (n == 16) return hi + asr16(lo + 32768L);
  int32_t t = hi + asr16(lo);  // floor(p*k / 2^16)
  return (asr32(t, uint8_t(n - 17)) + 1) >> 1;
}

// floor(x * b / 2^16) for a 32-bit coefficient, with 16x16->32 products.
ALWAYS_INLINE int32_t mul_wide(int16_t x, int32_t b) {
  return mul_ss(x, int16_t(asr16(b))) + asr16(mul_su(x, uint16_t(uint32_t(b) & 0xFFFFu)));
}

ALWAYS_INLINE int16_t sat16(int32_t v, uint8_t* flags) {
  if (v > 32767) { *flags |= Estimator::kSaturated; return 32767; }
  if (v < -32768) { *flags |= Estimator::kSaturated; return -32768; }
  return int16_t(v);
}

}  // namespace

Estimator::Estimator() : blob_(0), length_(0), n_in_(0), n_out_(0), head_(0), flags_(0),
                         cascade_(0), section_(0) {
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

int16_t Estimator::pwl(uint16_t* off, int16_t x) {
  uint8_t n;
  blob_->read(*off, &n, 1);
  uint16_t xs = uint16_t(*off + 1);
  // Segment k: the last breakpoint <= x among 0..n-2 (segment 0 also left of x[0]).
  uint8_t lo = 0, hi = uint8_t(n - 2);
  uint8_t b[2];
  while (lo < hi) {
    uint8_t mid = uint8_t((lo + hi + 1) >> 1);
    blob_->read(uint16_t(xs + 2 * mid), b, 2);
    if (le16(b) <= x) lo = mid; else hi = uint8_t(mid - 1);
  }
  uint8_t seg[3];
  blob_->read(uint16_t(xs + 2 * lo), b, 2);
  int16_t xk = le16(b);
  blob_->read(uint16_t(xs + 2 * n + 2 * lo), b, 2);
  int16_t yk = le16(b);
  blob_->read(uint16_t(xs + 4 * n + 3 * lo), seg, 3);
  int32_t dx = int32_t(x) - xk;                  // |dx| <= 65535
  // |dx| <= 65535, so dx * slope < 2^31: split dx into sign and 16-bit magnitude.
  int32_t p = dx >= 0 ? mul_su(le16(seg), uint16_t(dx)) : -mul_su(le16(seg), uint16_t(-dx));
  *off = uint16_t(*off + blob::pwl_len(n));
  return sat16(int32_t(yk) + round_shift(p, seg[2]), &flags_);
}

inline int32_t Estimator::cascade(uint16_t* off, uint8_t n, int16_t x) {
  int16_t* xh = xhist_[cascade_++];
  int16_t x0 = x, x1 = xh[0], x2 = xh[1];
  xh[1] = x1;
  xh[0] = x0;
  int32_t y = 0;
  uint8_t rec[blob::kSecLen32];
  for (uint8_t s = 0; s < n; ++s) {
    // One read covers a 16-bit section; a wide one needs its last 6 bytes as well.
    blob_->read(*off, rec, blob::kSecLen16);
    uint8_t fl = rec[0];
    bool wide = fl & blob::kSecWide;
    if (wide) {
      blob_->read(uint16_t(*off + blob::kSecLen16), rec + blob::kSecLen16,
                  uint8_t(blob::kSecLen32 - blob::kSecLen16));
    }
    *off = uint16_t(*off + (wide ? blob::kSecLen32 : blob::kSecLen16));
    const uint8_t* c = rec + blob::kSecFixedLen;
    // Numerator (FIR part of direct form I) in Q13 of the output.
    int32_t w;
    if (wide) {
      w = mul_wide(x0, le32(c)) + mul_wide(x1, le32(c + 4)) + mul_wide(x2, le32(c + 8));
      c += 12;
    } else {
      w = mul_ss(x0, le16(c)) + mul_ss(x1, le16(c + 2)) + mul_ss(x2, le16(c + 4));
      c += 6;
    }
    int32_t* ys = ystate_[section_++];
    int32_t y1 = ys[0], y2 = ys[1];
    // Every term is bounded by validate(): |W| <= 2^29, |base| <= 3 * 2^28, |P1| <= 2^28 + 1,
    // |P2| <= 2^27 + 1, so the int32 sum cannot overflow.
    int32_t acc = round_shift(w, rec[1]);
    if (fl & blob::kSecDelta) {
      // Delta form: y = 2y1 - y2 - alpha1 (y1 - y2) - alpha0 y2 (poles near z = 1).
      acc += 2 * y1 - y2;
      acc += mul_round(y1 - y2, le16(c), rec[2]);
      acc += mul_round(y2, le16(c + 2), rec[3]);
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
      acc += mul_round(y1, le16(c), rec[2]);
      acc += mul_round(y2, le16(c + 2), rec[3]);
    }
    if (acc > kStateMax) { y = kStateMax; flags_ |= kSaturated; }
    else if (acc < kStateMin) { y = kStateMin; flags_ |= kSaturated; }
    else y = acc;
    ys[1] = y1;
    ys[0] = y;
    // The next section's input history is this section's output history (shared state).
    x0 = q13_to_int16(y);
    x1 = q13_to_int16(y1);
    x2 = q13_to_int16(y2);
  }
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
  uint8_t rec[blob::kBranchRecLen];
  for (uint8_t j = 0; j < n_out_; ++j) {
    blob_->read(off, rec, blob::kOutputRecLen);
    off = uint16_t(off + blob::kOutputRecLen);
    uint8_t nb = rec[0], ofl = rec[1];
    int16_t out_offset = le16(rec + 2);
    int32_t sum = 0;  // Q13, |.| <= 3 * 2^28
    for (uint8_t b = 0; b < nb; ++b) {
      blob_->read(off, rec, blob::kBranchRecLen);
      off = uint16_t(off + blob::kBranchRecLen);
      int16_t u = delay_[rec[0]][(head_ - rec[1]) & (kDelayLen - 1)];
      int16_t x = sat16(int32_t(u) - le16(rec + 2), &flags_);
      uint8_t ns = rec[5];
      if (rec[4] & blob::kBranchHasF) x = pwl(&off, x);
      sum += cascade(&off, ns, x);
    }
    int16_t v = sat16(sum >> blob::kStateFrac, &flags_);
    if (ofl & blob::kOutHasG) v = pwl(&off, v);
    if (ofl & blob::kOutHasH2) {
      uint8_t ns;
      blob_->read(off, &ns, 1);
      off = uint16_t(off + 1);
      v = q13_to_int16(cascade(&off, ns, v));
    }
    estimate[j] = sat16(int32_t(v) + out_offset, &flags_);
  }
  return flags_;
}

}  // namespace est
