#include "model_blob.h"

#include <string.h>

#include "frame_codec.h"

namespace est {

void RamBlobReader::read(uint16_t offset, void* dst, uint8_t n) const {
  // Reads past the end give zeros: validate() never lets the estimator get there.
  uint8_t* out = static_cast<uint8_t*>(dst);
  for (uint8_t i = 0; i < n; ++i) {
    uint16_t at = uint16_t(offset + i);
    out[i] = at < size_ ? data_[at] : 0;
  }
}

namespace blob {
namespace {

uint8_t rd8(const BlobReader& r, uint16_t off) {
  uint8_t v;
  r.read(off, &v, 1);
  return v;
}

int16_t rd16(const BlobReader& r, uint16_t off) {
  uint8_t b[2];
  r.read(off, b, 2);
  return int16_t(uint16_t(b[0]) | uint16_t(b[1]) << 8);
}

int32_t rd32(const BlobReader& r, uint16_t off) {
  uint8_t b[4];
  r.read(off, b, 4);
  return int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
}

uint32_t mag(int32_t v) { return v < 0 ? uint32_t(0) - uint32_t(v) : uint32_t(v); }

// k 2^-n in Q28, rounded down (exact for n <= 28; below by less than one Q28 step beyond).
__attribute__((noinline)) int32_t q28(int16_t k, uint8_t n) {
  int32_t v = k;
  for (; n < 28; ++n) v *= 2;  // (a left shift of a negative value is undefined in C++)
  for (; n > 28; --n) v >>= 1;
  return v;
}

// Walks one PWL table at *off; false if it is malformed or would run past `end`.
bool check_pwl(const BlobReader& r, uint16_t* off, uint16_t end) {
  if (uint16_t(*off + 1) > end) return false;
  const uint8_t count = rd8(r, *off);
  const bool compact = count & layout::kTableCompact;
  const uint8_t n = count & uint8_t(~layout::kTableCompact);
  if (n < 2 || n > kMaxBreakpoints) return false;
  uint16_t len = pwl_len(count);
  if (uint32_t(*off) + len > end) return false;
  int16_t prev = rd16(r, uint16_t(*off + 1));
  for (uint8_t k = 1; k < n; ++k) {
    int16_t x = rd16(r, uint16_t(*off + 1 + 2 * k));
    if (x <= prev) return false;
    prev = x;
  }
  uint16_t seg = uint16_t(*off + 1 + 4 * n);
  for (uint8_t k = 0; !compact && k + 1 < n; ++k) {
    if (rd8(r, uint16_t(seg + 3 * k + 2)) > 30) return false;
  }
  *off = uint16_t(*off + len);
  return true;
}

}  // namespace

__attribute__((noinline)) bool section_stable(uint8_t fl, uint8_t n1, uint8_t n2, int16_t k1, int16_t k2) {
  // The feedback weights c_i = -a_i: direct form c1 = m1 + k1', c2 = m2 + k2'; delta form
  // c1 = 2 + k1', c2 = -1 - k1' + k2' (k' = k 2^-n). Stable iff A(1) = 1 - c1 - c2 > 0,
  // A(-1) = 1 + c1 - c2 > 0 and 1 + c2 > 0. In Q28 (|terms| <= 5 2^28: no int32 overflow) each
  // residue is low by less than one step, so a sum is within two steps of the true one:
  // requiring more than two keeps every accepted section stable (margins under 2^-27 are
  // refused), except A(1) of the delta form, whose sign is k2's, exactly (poles nearest z = 1).
  constexpr int32_t one = int32_t(1) << 28, slack = 2;
  const int32_t r1 = q28(k1, n1), r2 = q28(k2, n2);
  if (fl & kSecDelta) return k2 < 0 && r2 - r1 > slack;  // A(-1) = 4 + 2 k1' - k2' >= 2.5
  const int32_t c1 = (int32_t(((fl >> 2) & 7)) - 2) * one + r1, c2 = (int32_t(((fl >> 5) & 3)) - 1) * one + r2;
  return one - c1 - c2 > slack && one + c1 - c2 > slack && one + c2 > slack;
}

namespace {

bool check_cascade(const BlobReader& r, uint16_t* off, uint16_t end, uint8_t n) {
  if (n < 1 || n > kMaxSections) return false;
  for (uint8_t s = 0; s < n; ++s) {
    if (uint16_t(*off + kSecFixedLen) > end) return false;
    uint8_t fl = rd8(r, *off), sb = rd8(r, uint16_t(*off + 1));
    uint8_t n1 = rd8(r, uint16_t(*off + 2)), n2 = rd8(r, uint16_t(*off + 3));
    if (fl & 0x80) return false;
    uint8_t m1 = (fl >> 2) & 7, m2 = (fl >> 5) & 3;
    if (m1 > 4 || m2 > 2) return false;
    if ((fl & kSecDelta) && (m1 != 2 || m2 != 1)) return false;  // no base weights in delta form
    if (sb > 31 || n1 < 16 || n1 > 47 || n2 < 16 || n2 > 47) return false;
    bool wide = fl & kSecWide;
    uint16_t len = wide ? kSecLen32 : kSecLen16;
    if (uint32_t(*off) + len > end) return false;
    // Bound the numerator so that the step's int32 sums cannot overflow: |w| < 2^31 and
    // |round(w / 2^sb)| <= 2^29 (limits: MODEL_FORMAT.md).
    uint16_t p = uint16_t(*off + kSecFixedLen);
    uint32_t sum = 0;
    const uint16_t kp = uint16_t(p + (wide ? 12 : 6));
    if (!section_stable(fl, n1, n2, rd16(r, kp), rd16(r, uint16_t(kp + 2)))) return false;
    if (wide) {
      for (uint8_t k = 0; k < 3; ++k) {
        uint32_t m = mag(rd32(r, uint16_t(p + 4 * k)));
        if (m > 0xFFFF0000UL - sum) return false;
        sum += m;
      }
      if (sb < 2 && sum > (uint32_t(1) << (30 + sb)) - 65536UL) return false;
    } else {
      for (uint8_t k = 0; k < 3; ++k) sum += mag(rd16(r, uint16_t(p + 2 * k)));
      if (sum > 65535UL || (sb < 2 && sum > (uint32_t(1) << (14 + sb)))) return false;
    }
    *off = uint16_t(*off + len);
  }
  return true;
}

}  // namespace

uint16_t crc(const BlobReader& r, uint16_t n) {
  uint16_t c = 0xFFFF;
  uint8_t buf[16];
  for (uint16_t at = 0; at < n;) {
    uint16_t left = uint16_t(n - at);
    uint8_t k = left > sizeof(buf) ? uint8_t(sizeof(buf)) : uint8_t(left);
    r.read(at, buf, k);
    for (uint8_t i = 0; i < k; ++i) c = proto::crc16_update(c, buf[i]);
    at = uint16_t(at + k);
  }
  return c;
}

uint16_t stored_crc(const BlobReader& r, uint16_t length) { return uint16_t(rd16(r, uint16_t(length - kCrcLen))); }

bool read_header(const BlobReader& r, uint16_t length, Header* out, uint16_t max_length) {
  if (length < kHeaderLen + kCrcLen || length > max_length) return false;
  uint8_t h[kHeaderLen];
  r.read(0, h, kHeaderLen);
  if (h[kOffMagic] != kMagic0 || h[kOffMagic + 1] != kMagic1) return false;
  if (h[kOffVersion] != kFormatVersion) return false;
  uint8_t ni = h[kOffInputs], no = h[kOffOutputs];
  if (ni < 1 || ni > kMaxInputs || no < 1 || no > kMaxOutputs || h[kOffReserved] != 0) return false;
  uint16_t len = uint16_t(h[kOffLength] | uint16_t(h[kOffLength + 1]) << 8);
  if (len != length) return false;
  // Sample period and input scaling (compared as bits: no float code on the AVR).
  uint32_t ts = uint32_t(h[kOffTsUs]) | uint32_t(h[kOffTsUs + 1]) << 8 | uint32_t(h[kOffTsUs + 2]) << 16 |
                uint32_t(h[kOffTsUs + 3]) << 24;
  uint32_t lsb = uint32_t(h[kOffInputLsb]) | uint32_t(h[kOffInputLsb + 1]) << 8 | uint32_t(h[kOffInputLsb + 2]) << 16 |
                 uint32_t(h[kOffInputLsb + 3]) << 24;
  if (ts == 0 || ts > layout::kMaxTsUs || lsb != layout::kInputLsbBits) return false;
  if (out) {
    out->format_version = h[kOffVersion];
    out->n_inputs = ni;
    out->n_outputs = no;
    out->length = len;
    out->model_id = uint32_t(h[kOffModelId]) | uint32_t(h[kOffModelId + 1]) << 8 | uint32_t(h[kOffModelId + 2]) << 16 |
                    uint32_t(h[kOffModelId + 3]) << 24;
    memcpy(out->out_scale, h + kOffOutScale, sizeof(out->out_scale));  // little-endian float32
  }
  return true;
}

bool validate(const BlobReader& r, uint16_t length, uint16_t max_length, uint8_t* n_cascades, uint8_t* n_sections) {
  Header h;
  if (!read_header(r, length, &h, max_length)) return false;
  uint16_t end = uint16_t(length - kCrcLen);
  if (crc(r, end) != stored_crc(r, length)) return false;
  uint16_t off = kHeaderLen;
  uint8_t cascades = 0, sections = 0;
  for (uint8_t j = 0; j < h.n_outputs; ++j) {
    if (uint16_t(off + kOutputRecLen) > end) return false;
    uint8_t nb = rd8(r, off), fl = rd8(r, uint16_t(off + 1));
    if (nb < 1 || nb > kMaxBranches || (fl & ~(kOutHasG | kOutHasH2))) return false;
    off = uint16_t(off + kOutputRecLen);
    for (uint8_t b = 0; b < nb; ++b) {
      if (uint16_t(off + kBranchRecLen) > end) return false;
      uint8_t in = rd8(r, off), delay = rd8(r, uint16_t(off + 1));
      uint8_t bfl = rd8(r, uint16_t(off + 4)), ns = rd8(r, uint16_t(off + 5));
      if (in >= h.n_inputs || delay > kMaxDelay || (bfl & ~kBranchHasF)) return false;
      off = uint16_t(off + kBranchRecLen);
      if ((bfl & kBranchHasF) && !check_pwl(r, &off, end)) return false;
      if (!check_cascade(r, &off, end, ns)) return false;
      ++cascades;
      sections = uint8_t(sections + ns);
    }
    if ((fl & kOutHasG) && !check_pwl(r, &off, end)) return false;
    if (fl & kOutHasH2) {
      if (uint16_t(off + 1) > end) return false;
      uint8_t ns = rd8(r, off);
      off = uint16_t(off + 1);
      if (!check_cascade(r, &off, end, ns)) return false;
      ++cascades;
      sections = uint8_t(sections + ns);
    }
  }
  if (off != end) return false;
  if (n_cascades) *n_cascades = cascades;
  if (n_sections) *n_sections = sections;
  return true;
}

}  // namespace blob
}  // namespace est
