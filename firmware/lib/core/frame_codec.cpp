#include "frame_codec.h"

#include <string.h>
#if defined(__AVR__)
#include <util/crc16.h>
#endif

namespace proto {

namespace {

// Smallest encoded frame: code byte + header + crc (empty payload, no delimiter).
constexpr uint8_t kMinEncodedLen = 1 + kHeaderLen + kCrcLen;

inline void bump(uint16_t* counter) {
  if (*counter != 0xFFFF) ++*counter;
}

// COBS writer into a frame buffer: out[code_pos] holds the code byte of the open block.
struct CobsWriter {
  uint8_t* out;
  uint8_t code_pos;
  uint8_t n;
  void put(uint8_t b) {
    if (b == 0) {
      out[code_pos] = (uint8_t)(n - code_pos);
      code_pos = n++;
    } else {
      out[n++] = b;  // blocks never reach 254 bytes: a body is at most kMaxBodyLen
    }
  }
  uint8_t finish() {
    out[code_pos] = (uint8_t)(n - code_pos);
    out[n++] = 0;
    return n;
  }
};

// 1 << (i & 7) in a few instructions: the AVR has no barrel shifter, a variable shift loops.
inline uint8_t bit_mask(uint8_t i) {
  uint8_t m = (i & 4) ? 16 : 1;
  if (i & 2) m = (uint8_t)(m << 2);
  if (i & 1) m = (uint8_t)(m << 1);
  return m;
}

void reverse(uint8_t* a, uint8_t lo, uint8_t hi) {  // [lo, hi)
  while (lo + 1 < hi) {
    --hi;
    uint8_t t = a[lo];
    a[lo] = a[hi];
    a[hi] = t;
    ++lo;
  }
}

}  // namespace

uint16_t crc16_update(uint16_t crc, uint8_t byte) {
#if defined(__AVR__)
  return _crc_ccitt_update(crc, byte);  // avr-libc's hand-written assembly, same function
#else
  // Byte-wise form of the reflected CCITT polynomial (x^16 + x^12 + x^5 + 1).
  byte ^= (uint8_t)crc;
  byte ^= (uint8_t)(byte << 4);
  return (uint16_t)((((uint16_t)byte << 8) | (crc >> 8)) ^ (uint8_t)(byte >> 4) ^ ((uint16_t)byte << 3));
#endif
}

uint16_t crc16(const uint8_t* data, uint16_t len) {
  uint16_t crc = 0xFFFF;
  for (uint16_t i = 0; i < len; ++i) crc = crc16_update(crc, data[i]);
  return crc;
}

uint8_t encode_frame(uint8_t type, uint8_t seq, const uint8_t* payload, uint8_t len, uint8_t* out, uint8_t version) {
  if (len > kMaxPayload || (len > 0 && payload == nullptr) || out == nullptr) return 0;
  const uint8_t header[kHeaderLen] = {version, type, seq, len};
  CobsWriter w = {out, 0, 1};
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < kHeaderLen; ++i) {
    crc = crc16_update(crc, header[i]);
    w.put(header[i]);
  }
  for (uint8_t i = 0; i < len; ++i) {
    crc = crc16_update(crc, payload[i]);
    w.put(payload[i]);
  }
  w.put((uint8_t)crc);
  w.put((uint8_t)(crc >> 8));
  return w.finish();
}

void FrameDecoder::reset() {
  fill_ = 0;
  head_ = 0;
  overlong_ = false;
  buf_[0] = buf_[1] = buf_[2] = buf_[3] = 0;
  counters_ = DecoderCounters();
}

bool FrameDecoder::feed(uint8_t byte) {
  if (byte != 0) {
    if (fill_ < kMaxFrameLen) {
      buf_[fill_++] = byte;
    } else {
      // Overlong: keep the newest bytes, a valid frame may still end this chunk.
      if (!overlong_) {
        overlong_ = true;
        bump(&counters_.overlong);
      }
      buf_[head_] = byte;
      head_ = (uint8_t)(head_ + 1 == kMaxFrameLen ? 0 : head_ + 1);
    }
    return false;
  }
  const bool ok = end_of_chunk();
  fill_ = 0;
  head_ = 0;
  overlong_ = false;
  return ok;
}

bool FrameDecoder::end_of_chunk() {
  if (fill_ == 0) return false;  // repeated 0x00 (idle fill) is not a frame
  uint8_t first = 0;
  if (overlong_) {
    unwrap();  // already counted; its start is lost, so every suffix is a candidate
  } else {
    const Check c = check(0, true, false);
    if (c == kOk) {
      accept(0);
      return true;
    }
    count(c);
    first = 1;
  }
  // A valid frame preceded by garbage that held no 0x00: the longest valid suffix wins.
  // One backward pass marks the suffixes whose code chain ends exactly at the delimiter
  // (the chain from s continues the chain from s + code), so the search stays linear in
  // the chunk length apart from the rare suffixes whose header also looks right.
  uint8_t chain_ends[(kMaxFrameLen + 7) / 8];
  memset(chain_ends, 0, sizeof chain_ends);
  for (uint8_t s = fill_; s-- > first;) {
    const uint16_t next = (uint16_t)(s + buf_[s]);
    if (next == fill_ || (next < fill_ && (chain_ends[next >> 3] & bit_mask((uint8_t)next)))) {
      chain_ends[s >> 3] = (uint8_t)(chain_ends[s >> 3] | bit_mask(s));
    }
  }
  for (uint8_t s = first; (uint16_t)s + kMinEncodedLen <= fill_; ++s) {
    if (!(chain_ends[s >> 3] & bit_mask(s))) continue;
    // Exact shortcut: a non-zero length byte must sit, as data, at encoded position s + 4
    // (a code byte there decodes to 0), and equal the payload size of this suffix.
    const uint8_t payload_len = (uint8_t)(fill_ - s - kMinEncodedLen);
    if (payload_len != 0 && buf_[s + kHeaderLen] != payload_len) continue;
    // Exact too: with a first code above 2, version and type are the next two bytes.
    if (buf_[s] > 2 && (buf_[s + 1] >> 4) != kVersionMajor && buf_[s + 2] != msg::HELLO &&
        buf_[s + 2] != msg::HELLO_REPLY) {
      continue;
    }
    if (check(s, false, true) == kOk) {
      accept(s);
      return true;
    }
  }
  return false;
}

FrameDecoder::Check FrameDecoder::check(uint8_t start, bool need_reason, bool chain_ok) const {
  const uint8_t end = fill_;
  // The code-byte chain must end exactly at the delimiter. A code of 0xFF (no implicit
  // zero) would need 254 data bytes, more than any frame holds, so it fails here too.
  for (uint8_t pos = start; pos < end && !chain_ok;) {
    const uint8_t c = buf_[pos];
    if (c > end - pos) return kBadCobs;
    pos = (uint8_t)(pos + c);
  }
  // Every code byte but the first decodes to one 0x00, so the body is one byte shorter.
  const uint8_t body_len = (uint8_t)(end - start - 1);
  if (body_len < kHeaderLen + kCrcLen) return kBadLength;

  // Decoded byte i sits at encoded position start + 1 + i, or is 0 there if that is a code.
  uint8_t next_code = (uint8_t)(start + buf_[start]);
  uint8_t header[kHeaderLen];
  uint8_t p = (uint8_t)(start + 1);
  for (uint8_t i = 0; i < kHeaderLen; ++i, ++p) {
    if (p == next_code) {
      next_code = (uint8_t)(next_code + buf_[p]);
      header[i] = 0;
    } else {
      header[i] = buf_[p];
    }
  }
  Check verdict = kOk;
  const uint8_t len = header[3];
  const uint8_t type = header[1];
  // HELLO and HELLO_REPLY pass with any major, whatever their length in that major, so
  // that a mismatch can be reported rather than timed out.
  const bool foreign = (header[0] >> 4) != kVersionMajor;
  const bool exempt = type == msg::HELLO || type == msg::HELLO_REPLY;
  uint8_t min_len = 0, max_len = 0;
  if (len != body_len - kHeaderLen - kCrcLen || len > kMaxPayload) {
    verdict = kBadLength;
  } else if (foreign && !exempt) {
    verdict = kBadVersion;
  } else if (!payload_bounds(type, &min_len, &max_len)) {
    verdict = kUnknownType;
  } else if (!foreign && (len < min_len || len > max_len)) {
    verdict = kBadLength;
  }
  if (verdict != kOk && !need_reason) return verdict;

  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < kHeaderLen; ++i) crc = crc16_update(crc, header[i]);
  const uint8_t crc_at = (uint8_t)(body_len - kCrcLen);
  uint8_t received[kCrcLen] = {0, 0};
  for (uint8_t i = kHeaderLen; i < body_len; ++i, ++p) {
    uint8_t b;
    if (p == next_code) {
      next_code = (uint8_t)(next_code + buf_[p]);
      b = 0;
    } else {
      b = buf_[p];
    }
    if (i < crc_at) {
      crc = crc16_update(crc, b);
    } else {
      received[i - crc_at] = b;
    }
  }
  if (crc != (uint16_t)(received[0] | ((uint16_t)received[1] << 8))) return kBadCrc;
  return verdict;
}

void FrameDecoder::accept(uint8_t start) {
  // In place: the write index trails the read index, so nothing unread is overwritten.
  uint8_t next_code = (uint8_t)(start + buf_[start]);
  uint8_t w = 0;
  for (uint8_t p = (uint8_t)(start + 1); p < fill_; ++p) {
    if (p == next_code) {
      next_code = (uint8_t)(next_code + buf_[p]);
      buf_[w++] = 0;
    } else {
      buf_[w++] = buf_[p];
    }
  }
  bump(&counters_.frames);
}

void FrameDecoder::count(Check reason) {
  switch (reason) {
    case kBadCobs:
      bump(&counters_.bad_cobs);
      break;
    case kBadCrc:
      bump(&counters_.bad_crc);
      break;
    case kBadLength:
      bump(&counters_.bad_length);
      break;
    case kBadVersion:
      bump(&counters_.bad_version);
      break;
    case kUnknownType:
      bump(&counters_.unknown_type);
      break;
    case kOk:
      break;
  }
}

void FrameDecoder::unwrap() {
  reverse(buf_, 0, head_);
  reverse(buf_, head_, fill_);
  reverse(buf_, 0, fill_);
  head_ = 0;
}

}  // namespace proto
