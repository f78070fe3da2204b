// Fuzz driver of the command handlers: random valid frames of every host-to-device type with
// random payloads (and, less often, wrong lengths, echoed device-to-host frames, retries and
// unknown types) go through dev::Device with the real model store and estimator, under
// AddressSanitizer and UndefinedBehaviorSanitizer. Between frames the clock advances and
// sample ticks arrive.
//
// Invariants checked after every frame:
//   - every frame is answered by exactly one reply frame with its sequence number (ACK/NAK
//     naming its type, or the type's own reply);
//   - the outputs stay within limits (setpoints in MIN_SETPOINT_DKPA..0, masks of 3 bits)
//     and an accepted SET_OUTPUTS applied exactly what it asked;
//   - the link watchdog holds: outputs are never active longer than WATCHDOG_MS after the
//     last valid host command, and a silence longer than that always cuts them.
//
//   build/fuzz_commands N SEED      N frames (default 100000), seed (default 1)
// Prints the counts it measured; exits 1 on a broken invariant (a sanitizer finding aborts).
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <vector>

#include "device.h"
#include "frame_codec.h"
#include "model_link.h"
#include "protocol_messages.h"

namespace {

// xorshift64*: deterministic for a seed, independent of the C library.
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ULL + 1) {}
  uint32_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return (uint32_t)((s * 0x2545F4914F6CDD1DULL) >> 32);
  }
  uint32_t below(uint32_t n) { return n ? next() % n : 0; }
  bool chance(uint32_t percent) { return below(100) < percent; }
};

uint8_t g_eeprom[1024];

struct Hal : dev::Hal {
  Rng* rng = nullptr;
  uint32_t now_us = 0;
  dev::Outputs out{};
  std::vector<std::vector<uint8_t>> writes;  // one entry per serial_write call
  std::vector<uint8_t> rx;
  size_t rx_pos = 0;
  int adc_channel = -1;
  bool reset = false;

  uint32_t micros() override { return now_us; }
  uint32_t millis() override { return now_us / 1000; }
  void apply_outputs(const dev::Outputs& o) override { out = o; }
  bool adc_start(uint8_t ch) override {
    if (rng->chance(2)) return false;
    adc_channel = ch;
    now_us += 1200;  // a conversion at 860 SPS
    return true;
  }
  bool adc_finish(int16_t* c) override {
    if (adc_channel < 0 || rng->chance(1)) return false;
    *c = (int16_t)rng->next();
    adc_channel = -1;
    return true;
  }
  void adc_configure(uint8_t, uint8_t) override {}
  bool imu_read(int16_t e[3], uint8_t* cal) override {
    if (rng->chance(2)) return false;
    for (int i = 0; i < 3; ++i) e[i] = (int16_t)rng->next();
    *cal = (uint8_t)rng->below(4);
    return true;
  }
  bool adc_present() override { return true; }
  bool imu_present() override { return true; }
  int16_t serial_read() override { return rx_pos < rx.size() ? rx[rx_pos++] : -1; }
  void serial_write(const uint8_t* d, uint8_t n) override { writes.emplace_back(d, d + n); }
  uint8_t serial_tx_free() override { return 255; }
  uint8_t eeprom_read(uint16_t a) override { return g_eeprom[a & 1023]; }
  void eeprom_write(uint16_t a, uint8_t v) override { g_eeprom[a & 1023] = v; }
  void request_reset() override { reset = true; }
  uint16_t free_stack() override { return 500; }
  uint8_t reset_cause() override { return 0; }
};

struct Eeprom : est::Eeprom {
  uint8_t read(uint16_t a) override { return g_eeprom[a & 1023]; }
  void write(uint16_t a, uint8_t v) override { g_eeprom[a & 1023] = v; }
};

struct Reply {
  uint8_t type, seq;
  std::vector<uint8_t> payload;
};

// The frames written since the last call; CSV text of line mode is skipped.
std::vector<Reply> take_replies(Hal& hal) {
  std::vector<Reply> out;
  for (const std::vector<uint8_t>& w : hal.writes) {
    if (w.empty() || w.back() != 0) continue;  // a CSV line or header
    proto::FrameDecoder d;
    d.feed(0);  // a fresh decoder waits for a delimiter before its first frame
    for (uint8_t b : w) {
      if (d.feed(b))
        out.push_back(Reply{d.type(), d.seq(), std::vector<uint8_t>(d.payload(), d.payload() + d.length())});
    }
  }
  hal.writes.clear();
  return out;
}

uint8_t reply_type_of(uint8_t type) {
  namespace m = proto::msg;
  switch (type) {
    case m::HELLO:
      return m::HELLO_REPLY;
    case m::PING:
      return m::PONG;
    case m::MODEL_INFO:
      return m::MODEL_INFO_REPLY;
    case m::MODEL_READ:
      return m::MODEL_DATA;
    case m::REPLAY:
      return m::REPLAY_RESULT;
    case m::CALIBRATE_R0:
      return m::R0_REPLY;
    case m::STATUS:
      return m::STATUS_REPLY;
    case m::CONFIG_GET:
      return m::CONFIG_VALUE;
    case m::CONTROL_GAINS_GET:
      return m::CONTROL_GAINS_REPLY;
    default:
      return m::ACK;
  }
}

int g_failures = 0;
#define INVARIANT(cond, ...)                                  \
  do {                                                        \
    if (!(cond)) {                                            \
      if (++g_failures <= 20) {                               \
        printf("INVARIANT %s (frame %ld): ", #cond, (long)i); \
        printf(__VA_ARGS__);                                  \
        printf("\n");                                         \
      }                                                       \
    }                                                         \
  } while (0)

bool outputs_active(const dev::Outputs& o) {
  return o.pump_mask || o.valve_mask || o.setpoint_dkpa[0] || o.setpoint_dkpa[1] || o.setpoint_dkpa[2];
}

}  // namespace

int main(int argc, char** argv) {
  const long n_frames = argc > 1 ? atol(argv[1]) : 100000;
  const uint64_t seed = argc > 2 ? strtoull(argv[2], nullptr, 10) : 1;
  Rng rng(seed);
  memset(g_eeprom, 0xFF, sizeof g_eeprom);
  Hal hal;
  hal.rng = &rng;
  Eeprom ee;
  dev::ModelLink model(ee);
  model.boot();
  dev::Device device(hal, model);
  device.begin();
  take_replies(hal);

  // Every host-to-device type of the catalogue, and the device-to-host ones (echoes).
  std::vector<uint8_t> h2d, d2h;
  for (int t = 0; t < 256; ++t) {
    uint8_t lo, hi;
    if (proto::payload_bounds((uint8_t)t, &lo, &hi)) ((t & 0x80) ? d2h : h2d).push_back((uint8_t)t);
  }
  uint16_t session = 0, counter = 0;
  uint8_t seq = 0, last_type = 0, last_seq = 0;
  bool cache = false;  // the device holds a reply for (last_type, last_seq)
  uint32_t last_feed_ms = 0;
  std::vector<uint8_t> last_frame;
  uint8_t sent_type = 0, sent_seq = 0, sent_len = 0;
  uint8_t sent_payload[proto::kMaxPayload];
  long dropped = 0;
  uint16_t next_offset = 0;
  long answered = 0, acks = 0, naks = 0, retries = 0, echoes = 0, trips = 0, on_ms_max = 0, silences = 0;
  long per_type[256] = {0}, nak_per_type[256] = {0};

  for (long i = 0; i < n_frames; ++i) {
    hal.now_us += rng.below(30000);
    // ------------------------------------------------------------ choose a frame
    uint8_t type, seq_sent, lo = 0, hi = 0;
    uint8_t payload[proto::kMaxPayload];
    uint8_t len = 0;
    const uint32_t pick = rng.below(1000);

    if (pick < 20 && !last_frame.empty()) {
      // the host's retry: the same bytes again
      type = sent_type;
      seq_sent = sent_seq;
      len = sent_len;
      memcpy(payload, sent_payload, len);
      ++retries;
    } else {
      if (pick < 40) {
        type = d2h[rng.below((uint32_t)d2h.size())];  // an echo of the board's own frame
        ++echoes;
      } else if (pick < 45) {
        type = (uint8_t)rng.below(0x80);  // any type, mostly unknown
      } else {
        type = h2d[rng.below((uint32_t)h2d.size())];
      }
      const bool known = proto::payload_bounds(type, &lo, &hi);
      len = known && !rng.chance(10) ? (uint8_t)(lo + rng.below((uint32_t)(hi - lo + 1)))
                                     : (uint8_t)rng.below(proto::kMaxPayload + 1);
      for (uint8_t k = 0; k < len; ++k) payload[k] = (uint8_t)rng.next();
      namespace m = proto::msg;
      // Structure where random bytes would almost never reach the interesting paths.
      if (type == m::SET_OUTPUTS && len == proto::SetOutputs::kMinLen) {
        proto::SetOutputs so;
        for (int c = 0; c < 3; ++c) so.setpoint_dkpa[c] = rng.chance(30) ? 0 : (int16_t)(-(int)rng.below(900) + 50);
        so.pump_mask = (uint8_t)rng.below(rng.chance(90) ? 8 : 256);
        so.valve_mask = (uint8_t)rng.below(rng.chance(90) ? 8 : 256);
        so.session = rng.chance(80) ? session : (uint16_t)rng.next();
        so.counter = rng.chance(80) ? ++counter : (uint16_t)rng.next();
        so.encode(payload);
      } else if (type == m::CONFIG_SET && len == proto::ConfigSet::kMinLen) {
        payload[0] = (uint8_t)rng.below(20);
        proto::config::KeyInfo ki;
        if (proto::config::key_info(payload[0], &ki) && rng.chance(70))
          proto::put_i32(payload + 1, ki.min + (int32_t)(rng.next() % (uint32_t)((int64_t)ki.max - ki.min + 1)));
      } else if (type == m::START_STREAM && len == proto::StartStream::kMinLen && rng.chance(70)) {
        proto::put_u16(payload, (uint16_t)(10 + rng.below(200)));
        payload[2] = (uint8_t)rng.below(32);
      } else if (type == m::MODEL_CHUNK && len >= 2 && rng.chance(70)) {
        proto::put_u16(payload, next_offset);  // continues a write in progress
      } else if (type == m::MODEL_READ && len >= 2 && rng.chance(70)) {
        proto::put_u16(payload, (uint16_t)rng.below(1100));
      } else if (type == m::MODEL_BEGIN && len == proto::ModelBegin::kMinLen && rng.chance(70)) {
        proto::put_u16(payload, (uint16_t)rng.below(1100));
      } else if (type == m::CALIBRATE_R0 && len == 2 && rng.chance(70)) {
        payload[0] = (uint8_t)rng.below(66);
        payload[1] = (uint8_t)rng.below(9);
      } else if (type == m::SET_WATCHDOG && len == 2 && rng.chance(70)) {
        proto::put_u16(payload, (uint16_t)(90 + rng.below(1000)));
      }
      seq_sent = ++seq;
      uint8_t buf[proto::kMaxFrameLen];
      const uint8_t n = proto::encode_frame(type, seq_sent, payload, len, buf);
      last_frame.assign(buf, buf + n);
      sent_type = type;
      sent_seq = seq_sent;
      sent_len = len;
      memcpy(sent_payload, payload, len);
    }
    ++per_type[type];
    // What the device must do with it (the watchdog model of the protocol).
    // The frame decoder drops unknown types and lengths outside the type's bounds (HELLO
    // excepted) unanswered; the rest reach the command handler.
    uint8_t blo = 0, bhi = 0;
    const bool known = proto::payload_bounds(type, &blo, &bhi);
    const bool delivered = known && len >= blo && len <= bhi;
    const bool command = delivered && !(type & 0x80);
    const bool dup = delivered && cache && type == last_type && seq_sent == last_seq && type != proto::msg::HELLO;
    const bool valid = command;
    if (delivered && !dup) {
      last_type = type;
      last_seq = seq_sent;
    }

    // ------------------------------------------------------------ deliver and check
    const bool was_on = outputs_active(hal.out);
    const uint32_t feed_before = last_feed_ms;
    hal.rx.insert(hal.rx.end(), last_frame.begin(), last_frame.end());
    device.poll();
    if (valid) last_feed_ms = hal.millis();
    const uint32_t now_ms = hal.millis();
    const uint16_t timeout = device.config().watchdog_ms;
    // The watchdog check of this poll ran after the frame was handled.
    if (was_on && !valid && now_ms - feed_before > timeout) {
      INVARIANT(!outputs_active(hal.out), "outputs on %u ms after the last command (timeout %u)",
                (unsigned)(now_ms - feed_before), timeout);
    }
    if (outputs_active(hal.out)) {
      const long on_ms = (long)(now_ms - last_feed_ms);
      if (on_ms > on_ms_max) on_ms_max = on_ms;
      INVARIANT(on_ms <= timeout, "outputs on %ld ms after the last valid command (timeout %u)", on_ms, timeout);
    }
    std::vector<Reply> replies = take_replies(hal);
    int answers = 0;
    for (const Reply& r : replies) {
      if (r.type == proto::msg::SAMPLE || r.type == proto::msg::CONTROL_SAMPLE || r.type == proto::msg::ERROR) {
        if (r.type == proto::msg::ERROR && r.payload.size() >= 3 &&
            proto::get_i16(r.payload.data() + 1) == (int16_t)proto::flag::WATCHDOG_TRIPPED)
          ++trips;
        continue;
      }
      ++answers;
      INVARIANT(r.seq == seq_sent, "reply seq %u to seq %u", r.seq, seq_sent);
      if (r.type == proto::msg::ACK || r.type == proto::msg::NAK) {
        INVARIANT(!r.payload.empty() && r.payload[0] == type, "ACK/NAK names type 0x%02x, sent 0x%02x",
                  r.payload.empty() ? 0 : r.payload[0], type);
        r.type == proto::msg::ACK ? ++acks : ++naks;
        if (r.type == proto::msg::NAK) ++nak_per_type[type];
        if (r.type == proto::msg::ACK && !dup && type == proto::msg::MODEL_BEGIN) next_offset = 0;
        if (r.type == proto::msg::ACK && !dup && type == proto::msg::MODEL_CHUNK)
          next_offset = (uint16_t)(next_offset + len - 2);
        if (r.type == proto::msg::ACK && type == proto::msg::SET_OUTPUTS && !dup) {
          proto::SetOutputs so;
          so.decode(payload, proto::SetOutputs::kMinLen);
          INVARIANT(memcmp(so.setpoint_dkpa, hal.out.setpoint_dkpa, sizeof so.setpoint_dkpa) == 0 &&
                        so.pump_mask == hal.out.pump_mask && so.valve_mask == hal.out.valve_mask,
                    "SET_OUTPUTS acknowledged but not applied");
        }
      } else {
        INVARIANT(command && r.type == reply_type_of(type), "type 0x%02x answered by 0x%02x", type, r.type);
        if (r.type == proto::msg::HELLO_REPLY) {
          proto::HelloReply h;
          if (h.decode(r.payload.data(), (uint8_t)r.payload.size())) session = h.session, counter = 0;
        }
      }
    }
    INVARIANT(answers == (delivered ? 1 : 0), "type 0x%02x seq %u len %u got %d answers", type, seq_sent, len, answers);
    answered += answers == 1;
    dropped += !delivered;
    if (delivered && !dup) cache = type != proto::msg::HELLO;
    const dev::Outputs& o = hal.out;
    for (int c = 0; c < 3; ++c)
      INVARIANT(o.setpoint_dkpa[c] <= 0 && o.setpoint_dkpa[c] >= -800, "setpoint %d", o.setpoint_dkpa[c]);
    INVARIANT((o.pump_mask | o.valve_mask) < 8, "masks %u %u", o.pump_mask, o.valve_mask);
    // ------------------------------------------------------------ between frames
    if (device.streaming() && rng.chance(50)) {
      device.on_sample_ticks((uint8_t)(1 + rng.below(3)), hal.now_us);
      take_replies(hal);
    }
    if (rng.chance(1)) {  // the host falls silent for longer than the timeout
      const bool on = outputs_active(hal.out);
      hal.now_us += (uint32_t)(timeout + 1 + rng.below(50)) * 1000u;
      device.poll();
      INVARIANT(!outputs_active(hal.out), "outputs still on after a silence of more than %u ms", timeout);
      silences += on;
      for (const Reply& r : take_replies(hal))
        trips += r.type == proto::msg::ERROR && r.payload.size() >= 3 &&
                 proto::get_i16(r.payload.data() + 1) == (int16_t)proto::flag::WATCHDOG_TRIPPED;
    }
    hal.reset = false;
  }
  printf(
      "fuzz_commands: %ld frames (seed %llu): %ld answered once, %ld ACK, %ld NAK, %ld retries, "
      "%ld echoes, %ld dropped by the decoder; %ld watchdog trips, %ld silences with outputs on; outputs on at most "
      "%ld ms "
      "after the last command\n",
      n_frames, (unsigned long long)seed, answered, acks, naks, retries, echoes, dropped, trips, silences, on_ms_max);
  printf("frames (refused) per host-to-device type:");
  for (int t = 0; t < 0x80; ++t) {
    uint8_t a, b;
    if (proto::payload_bounds((uint8_t)t, &a, &b)) printf(" 0x%02x:%ld(%ld)", t, per_type[t], nak_per_type[t]);
  }
  printf("\n%s\n", g_failures ? "FAILED" : "all invariants held");
  return g_failures ? 1 : 0;
}
