// Frames of the porosense wire protocol (protocol/spec.md):
//   frame = COBS(header | payload | crc) 0x00
//   header = version (major*16+minor), type, sequence, payload length (u8 each)
//   crc = CRC-16/MCRF4XX over header and payload, low byte first ("123456789" -> 0x6F91)
// Pure C++: no Arduino header, no heap, one fixed buffer per decoder.
#pragma once
#include <stdint.h>

#include "protocol_messages.h"

namespace proto {

constexpr uint8_t kHeaderLen = 4, kCrcLen = 2;
// Largest body (header + payload + crc) and its encoding: COBS adds one code byte per
// 254 bytes plus one, so 2 is a safe bound; plus the 0x00 delimiter.
constexpr uint8_t kMaxBodyLen = kHeaderLen + kMaxPayload + kCrcLen;
constexpr uint8_t kMaxFrameLen = kHeaderLen + kMaxPayload + kCrcLen + 2 + 1;

// One step of CRC-16/MCRF4XX (reflected poly 0x8408, no final xor); start from 0xFFFF.
// Same as avr-libc's _crc_ccitt_update.
uint16_t crc16_update(uint16_t crc, uint8_t byte);
uint16_t crc16(const uint8_t* data, uint16_t len);

// Writes COBS(header|payload|crc) + 0x00 into out (at least kMaxFrameLen bytes; must not
// overlap payload). Returns the frame length including the delimiter, 0 when len exceeds
// kMaxPayload or payload is null with len > 0.
uint8_t encode_frame(uint8_t type, uint8_t seq, const uint8_t* payload, uint8_t len, uint8_t* out,
                     uint8_t version = kVersionByte);

// Why frames were dropped. Every counter saturates at 0xFFFF.
struct DecoderCounters {
  uint16_t frames;        // valid frames delivered
  uint16_t bad_cobs;      // the code-byte chain does not end exactly at the delimiter
  uint16_t bad_crc;       // CRC mismatch
  uint16_t bad_length;    // body shorter than header+crc, header length disagrees with the
                          // frame, or outside the type's payload bounds
  uint16_t bad_version;   // protocol major other than ours (HELLO/HELLO_REPLY exempt)
  uint16_t unknown_type;  // type not in the catalogue
  uint16_t overlong;      // more than kMaxFrameLen bytes without a delimiter
};

// Incremental decoder: feed received bytes one at a time. A chunk (bytes up to a 0x00) that
// is not a valid frame is counted once by its first failing check; the decoder then looks
// for a valid frame that ends the chunk (a frame preceded by garbage without a 0x00), and
// after an overlong chunk it keeps the last kMaxFrameLen bytes for the same search.
class FrameDecoder {
 public:
  FrameDecoder() { reset(); }

  // Consume one byte; true when a valid frame is ready (valid until the next feed).
  bool feed(uint8_t byte);

  uint8_t version() const { return buf_[0]; }
  uint8_t type() const { return buf_[1]; }
  uint8_t seq() const { return buf_[2]; }
  const uint8_t* payload() const { return buf_ + kHeaderLen; }
  uint8_t length() const { return buf_[3]; }

  const DecoderCounters& counters() const { return counters_; }
  // Forget the partial chunk and zero the counters.
  void reset();

 private:
  enum Check : uint8_t { kOk = 0, kBadCobs, kBadCrc, kBadLength, kBadVersion, kUnknownType };

  bool end_of_chunk();
  // Checks buf_[start, fill_) as one encoded frame without modifying it. With
  // need_reason false the answer is only ok / not ok, and the CRC is skipped when a
  // cheaper header check already fails; chain_ok skips the COBS chain walk.
  Check check(uint8_t start, bool need_reason, bool chain_ok) const;
  void accept(uint8_t start);  // decode buf_[start, fill_) in place to buf_[0..]
  void count(Check reason);
  void unwrap();  // rotate the ring so its oldest byte is at buf_[0]

  uint8_t buf_[kMaxFrameLen];
  uint8_t fill_;  // bytes of the current chunk held in buf_
  uint8_t head_;  // oldest byte once the chunk has wrapped (overlong)
  bool overlong_;
  DecoderCounters counters_;
};

}  // namespace proto
