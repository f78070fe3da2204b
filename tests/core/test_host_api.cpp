// The host library's C interface (host_api.h) under the sanitizers: boot, a command and its
// reply, sample timing from the 1 kHz tick, overruns, the host-link watchdog, the ADC model
// and an injected power loss in the model region of the EEPROM.
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "frame_codec.h"
#include "host_api.h"
#include "protocol_messages.h"

namespace {

uint8_t g_seq = 0;

void send(ps_core* c, uint8_t type, const uint8_t* payload, uint8_t len) {
  uint8_t frame[proto::kMaxFrameLen];
  const uint8_t n = proto::encode_frame(type, ++g_seq, payload, len, frame);
  ps_feed(c, frame, n);
  ps_poll(c);
}

// Decodes every frame in what the core sent; returns how many, the last one in *dec.
int frames(ps_core* c, proto::FrameDecoder* dec, uint8_t want_type, proto::Sample* last) {
  uint8_t buf[4096];
  const uint32_t n = ps_take(c, buf, sizeof buf);
  int count = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (dec->feed(buf[i]) && dec->type() == want_type) {
      ++count;
      if (last) last->decode(dec->payload(), dec->length());
    }
  }
  return count;
}

}  // namespace

int main() {
  ps_core* c = ps_create();
  const double volts[3] = {2.5, 2.5, 2.5};  // R = R0 = 1 kOhm: dR 0
  const double euler[3] = {10.0, -2.0, 0.5};
  ps_set_inputs(c, volts, euler);
  ps_boot(c, PS_RESET_POWER_ON, 0);
  proto::FrameDecoder dec;

  // HELLO opens the session that commands turning outputs on must name.
  send(c, proto::msg::HELLO, 0, 0);
  proto::HelloReply hello;
  {
    uint8_t buf[256];
    const uint32_t n = ps_take(c, buf, sizeof buf);
    int replies = 0;
    for (uint32_t i = 0; i < n; ++i)
      if (dec.feed(buf[i]) && dec.type() == proto::HelloReply::kType) {
        hello.decode(dec.payload(), dec.length());
        ++replies;
      }
    CHECK(replies == 1);
  }

  // Streaming at 100 Hz: one SAMPLE per 10 ms of device time, on whole milliseconds.
  proto::StartStream ss;
  ss.rate_hz = 100;
  ss.channel_mask = 0x01 | proto::chan::IMU;
  uint8_t p[16];
  send(c, proto::StartStream::kType, p, ss.encode(p));
  CHECK(frames(c, &dec, proto::Ack::kType, 0) == 1);
  int64_t prev = -1;
  int samples = 0;
  proto::Sample s;
  for (int k = 0; k < 50; ++k) {
    const int64_t t = ps_next_tick(c);
    CHECK(t > 0 && t % 1000 == 0);
    if (prev >= 0) CHECK_MSG(t - prev == 10000, "tick spacing %lld", (long long)(t - prev));
    prev = t;
    uint8_t out[256];
    uint32_t n_out = 0;
    ps_state st;
    CHECK(ps_step(c, (uint64_t)t, volts, euler, 255, out, sizeof out, &n_out, &st) == 1);
    for (uint32_t i = 0; i < n_out; ++i)
      if (dec.feed(out[i]) && dec.type() == proto::Sample::kType) {
        s.decode(dec.payload(), dec.length());
        ++samples;
      }
    CHECK(s.t_us == (uint32_t)t);
  }
  CHECK(samples == 50);
  CHECK_MSG(s.adc[0] == 20000, "2.5 V at +-4.096 V full scale: %d counts", s.adc[0]);  // 2.5 / 125 uV
  CHECK_MSG(s.dr_centi[0] == 0, "dR %d", s.dr_centi[0]);
  CHECK(s.euler_16[0] == 160 && s.euler_16[1] == -32 && s.euler_16[2] == 8);
  CHECK(!(s.status & proto::flag::OVERRUN));

  // The clock jumps three periods: the firmware sees the missed ticks as overruns.
  ps_set_inputs(c, volts, euler);
  CHECK(ps_run_to(c, (uint64_t)prev + 30000) == 3);
  CHECK(frames(c, &dec, proto::Sample::kType, &s) == 1 && (s.status & proto::flag::OVERRUN));

  // Outputs on, then silence longer than the watchdog: the firmware cuts them.
  proto::SetOutputs so;
  memset(&so, 0, sizeof so);
  so.setpoint_dkpa[0] = -200;
  so.pump_mask = 1;
  so.valve_mask = 1;
  so.session = hello.session;
  so.counter = 1;
  send(c, proto::SetOutputs::kType, p, so.encode(p));
  ps_state st;
  ps_state_get(c, &st);
  CHECK(st.pump_mask == 1 && st.setpoint_dkpa[0] == -200 && st.streaming);
  send(c, proto::msg::STOP_STREAM, 0, 0);
  ps_set_time(c, (uint64_t)prev + 2000000);
  ps_poll(c);
  ps_state_get(c, &st);
  CHECK(st.pump_mask == 0 && st.valve_mask == 0 && st.setpoint_dkpa[0] == 0);
  CHECK(st.flags & proto::flag::WATCHDOG_TRIPPED);

  // A power loss at the first EEPROM write of the model region (the first chunk of a model).
  uint8_t drop[4096];
  ps_take(c, drop, sizeof drop);
  ps_fail_after_writes(c, 0, 64);
  uint8_t begin[5] = {0, 1, 0x34, 0x12, 2};  // length 256, crc 0x1234, format 2
  send(c, proto::msg::MODEL_BEGIN, begin, sizeof begin);
  ps_take(c, drop, sizeof drop);
  uint8_t chunk[2 + 64] = {0, 0};
  memset(chunk + 2, 0x5A, 64);
  send(c, proto::msg::MODEL_CHUNK, chunk, sizeof chunk);
  ps_state_get(c, &st);
  CHECK(st.power_lost);
  CHECK(ps_take(c, drop, sizeof drop) == 0);  // nothing leaves a board without power
  ps_boot(c, PS_RESET_POWER_ON, 0);
  ps_state_get(c, &st);
  CHECK(!st.power_lost && !st.streaming && st.pump_mask == 0);

  ps_destroy(c);
  printf("host_api: %d checks, %d failures\n", g_checks, g_failures);
  return g_failures ? 1 : 0;
}
