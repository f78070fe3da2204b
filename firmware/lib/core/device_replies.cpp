// Replies to commands (cached for a duplicate) and the unsolicited SAMPLE and ERROR frames.
#include "device.h"

#include "device_util.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

void Device::reply(uint8_t type, const uint8_t* payload, uint8_t len) {
  cached_len_ = proto::encode_frame(type, cmd_seq_, payload, len, cached_);
  if (cached_len_ == 0) return;
  hal_.serial_write(cached_, cached_len_);
  counters_.tx_frames = sat_inc32(counters_.tx_frames);
}

void Device::ack() {
  proto::Ack a;
  a.acked_type = last_type_;
  uint8_t buf[proto::Ack::kMaxLen];
  reply(proto::Ack::kType, buf, a.encode(buf));
}

void Device::nak(uint8_t code, int16_t detail) {
  proto::Nak n;
  n.acked_type = last_type_;
  n.code = code;
  n.detail = detail;
  uint8_t buf[proto::Nak::kMaxLen];
  reply(proto::Nak::kType, buf, n.encode(buf));
}

void Device::send_unsolicited(uint8_t type, const uint8_t* payload, uint8_t len) {
  // SAMPLE and ERROR number themselves with separate counters; a dropped frame still takes
  // its number, so the host sees the gap.
  uint8_t* seq = type == proto::msg::ERROR ? &error_seq_ : &telemetry_seq_;
  uint8_t frame[proto::kMaxFrameLen];
  const uint8_t n = proto::encode_frame(type, (*seq)++, payload, len, frame);
  if (n == 0) return;
  if (hal_.serial_tx_free() < n) {
    counters_.dropped_telemetry = sat_add16(counters_.dropped_telemetry, 1);
    return;
  }
  hal_.serial_write(frame, n);
  counters_.tx_frames = sat_inc32(counters_.tx_frames);
}

void Device::send_error(uint8_t code, int16_t detail, uint32_t t_us) {
  proto::Error e;
  e.code = code;
  e.detail = detail;
  e.t_us = t_us;
  uint8_t buf[proto::Error::kMaxLen];
  send_unsolicited(proto::Error::kType, buf, e.encode(buf));
}

}  // namespace dev
