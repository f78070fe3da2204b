#include "estimator.h"

#include <string.h>

namespace est {
namespace {

using blob::kStateMax;
using blob::kStateMin;

inline int16_t le16(const uint8_t* p) { return int16_t(uint16_t(p[0]) | uint16_t(p[1]) << 8); }
inline int32_t le32(const uint8_t* p) {
  return int32_t(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
}

// Arithmetic right shift in byte steps first: a variable shift is a bit loop on the AVR.
inline int32_t asr32(int32_t v, uint8_t s) {
  if (s >= 16) { v >>= 16; s = uint8_t(s - 16); }
  if (s >= 8) { v >>= 8; s = uint8_t(s - 8); }
  while (s) { v >>= 1; --s; }
  return v;
}

// round(v / 2^s), ties up; the form avoids overflow of v + 2^(s-1).
inline int32_t round_shift(int32_t v, uint8_t s) {
  if (s == 0) return v;
  return (asr32(v, uint8_t(s - 1)) + 1) >> 1;
}

// 16x16->32 products: avr-gcc turns these into its cheap widening multiply routines.
inline int32_t mul_ss(int16_t a, int16_t b) { return int32_t(a) * int32_t(b); }
// a * b for unsigned b, through a signed product: b = (b - 2^15) + 2^15.
inline int32_t mul_su(int16_t a, uint16_t b) {
  return mul_ss(a, int16_t(b ^ 0x8000u)) + int32_t(a) * 32768L;
}

// round(p * k / 2^n), ties up, for |p| <= 2^30 and 16 <= n <= 47, with two 16x16->32
// products: p*k = ph*k*2^16 + pl*k with pl unsigned.
inline int32_t mul_round(int32_t p, int16_t k, uint8_t n) {
  int32_t hi = mul_ss(int16_t(p >> 16), k);
  int32_t lo = mul_su(k, uint16_t(uint32_t(p) & 0xFFFFu));
  if (n == 16) return hi + ((lo + 32768L) >> 16);
  int32_t t = hi + (lo >> 16);  // floor(p*k / 2^16)
  return (asr32(t, uint8_t(n - 17)) + 1) >> 1;
}

// floor(x * b / 2^16) for a 32-bit coefficient, with 16x16->32 products.
inline int32_t mul_wide(int16_t x, int32_t b) {
  return mul_ss(x, int16_t(b >> 16)) + (mul_su(x, uint16_t(uint32_t(b) & 0xFFFFu)) >> 16);
}

// A 34-bit sum kept as int32 plus a count of wraps: exact, without 64-bit library calls.
struct Acc {
  int32_t lo;
  int8_t wraps;
  explicit Acc(int32_t v) : lo(v), wraps(0) {}
  void add(int32_t v) {
    if (__builtin_add_overflow(lo, v, &lo)) wraps = int8_t(wraps + (v > 0 ? 1 : -1));
  }
};

inline int16_t sat16(int32_t v, uint8_t* flags) {
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

int32_t Estimator::cascade(uint16_t* off, uint8_t n, int16_t x) {
  int16_t* xh = xhist_[cascade_++];
  int16_t x0 = x, x1 = xh[0], x2 = xh[1];
  xh[1] = x1;
  xh[0] = x0;
  int32_t y = 0;
  uint8_t rec[blob::kSecLen32];
  for (uint8_t s = 0; s < n; ++s) {
    blob_->read(*off, rec, blob::kSecFixedLen);
    uint8_t fl = rec[0];
    bool wide = fl & blob::kSecWide;
    uint8_t len = wide ? blob::kSecLen32 : blob::kSecLen16;
    blob_->read(uint16_t(*off + blob::kSecFixedLen), rec + blob::kSecFixedLen,
                uint8_t(len - blob::kSecFixedLen));
    *off = uint16_t(*off + len);
    const uint8_t* c = rec + blob::kSecFixedLen;
    // Numerator (FIR part of direct form I) in Q14 of the output.
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
    Acc acc(round_shift(w, rec[1]));
    if (fl & blob::kSecDelta) {
      // Delta form: y = 2y1 - y2 - alpha1 (y1 - y2) - alpha0 y2 (poles near z = 1).
      acc.add(2 * y1 - y2);  // |.| < 3 * 2^29
      acc.add(mul_round(y1 - y2, le16(c), rec[2]));
      acc.add(mul_round(y2, le16(c + 2), rec[3]));
    } else {
      // Direct form with integer base weights m1, m2 and residues |k| <= 1/2.
      int32_t base;
      switch ((fl >> 2) & 7) {
        case 0: base = -2 * y1; break;
        case 1: base = -y1; break;
        case 3: base = y1; break;
        case 4: base = 2 * y1; break;
        default: base = 0; break;
      }
      switch ((fl >> 5) & 3) {
        case 0: base -= y2; break;
        case 2: base += y2; break;
        default: break;
      }
      acc.add(base);  // |.| <= 3 * 2^29
      acc.add(mul_round(y1, le16(c), rec[2]));
      acc.add(mul_round(y2, le16(c + 2), rec[3]));
    }
    if (acc.wraps > 0 || (acc.wraps == 0 && acc.lo > kStateMax)) { y = kStateMax; flags_ |= kSaturated; }
    else if (acc.wraps < 0 || acc.lo < kStateMin) { y = kStateMin; flags_ |= kSaturated; }
    else y = acc.lo;
    ys[1] = y1;
    ys[0] = y;
    // The next section's input history is this section's output history (shared state).
    x0 = int16_t(y >> blob::kStateFrac);
    x1 = int16_t(y1 >> blob::kStateFrac);
    x2 = int16_t(y2 >> blob::kStateFrac);
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
    int32_t sum = 0;  // Q14, |.| <= 3 * 2^29
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
      v = int16_t(cascade(&off, ns, v) >> blob::kStateFrac);
    }
    estimate[j] = sat16(int32_t(v) + out_offset, &flags_);
  }
  return flags_;
}

}  // namespace est
