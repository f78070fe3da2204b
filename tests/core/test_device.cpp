// Host tests of the device core (firmware/lib/core/device.*, device_config.*, sensing.*,
// link_watchdog.h, rate_divider.h) against a fake board: duplicate commands, output limits,
// the host-link watchdog, overrun counting, dR arithmetic, the configuration store.
#include "check.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <vector>

#include "device.h"
#include "frame_codec.h"
#include "link_watchdog.h"
#include "protocol_messages.h"
#include "rate_divider.h"
#include "f32_bits.h"
#include "sensing.h"

namespace r = proto::result;
namespace f = proto::flag;

// ---------------------------------------------------------------- fakes

struct FakeHal : dev::Hal {
  uint32_t now_us = 0;
  dev::Outputs out{};
  int apply_calls = 0;
  bool adc_ok = true, imu_ok = true;
  int16_t adc_counts[3] = {20000, 20000, 20000};
  int adc_reads = 0;
  int16_t euler[3] = {16, 32, 48};
  uint8_t cal = 3;
  std::vector<uint8_t> rx;
  size_t rx_pos = 0;
  std::vector<uint8_t> tx;
  uint8_t tx_free = 255;
  uint8_t eeprom[1024];
  int eeprom_writes = 0;
  int eeprom_write_limit = -1;  // >= 0: writes beyond this many are lost (power cut)
  bool reset = false;

  FakeHal() { memset(eeprom, 0xFF, sizeof eeprom); }
  uint32_t micros() override { return now_us; }
  uint32_t millis() override { return now_us / 1000; }
  void apply_outputs(const dev::Outputs& o) override {
    out = o;
    ++apply_calls;
  }
  int adc_channel = -1;       // conversion in progress
  int adc_dead_channel = -1;  // this channel's conversion never starts
  bool adc_start(uint8_t ch) override {
    ++adc_reads;
    if (!adc_ok || ch == adc_dead_channel) return false;
    adc_channel = ch;
    return true;
  }
  bool adc_finish(int16_t* c) override {
    if (!adc_ok || adc_channel < 0) return false;
    *c = adc_counts[adc_channel];
    adc_channel = -1;
    return true;
  }
  void adc_configure(uint8_t, uint8_t) override {}
  bool imu_read(int16_t e[3], uint8_t* c) override {
    if (!imu_ok) return false;
    memcpy(e, euler, sizeof euler);
    *c = cal;
    return true;
  }
  bool adc_present() override { return adc_ok; }
  bool imu_present() override { return imu_ok; }
  int16_t serial_read() override { return rx_pos < rx.size() ? rx[rx_pos++] : -1; }
  void serial_write(const uint8_t* d, uint8_t n) override { tx.insert(tx.end(), d, d + n); }
  uint8_t serial_tx_free() override { return tx_free; }
  uint8_t eeprom_read(uint16_t a) override { return eeprom[a]; }
  void eeprom_write(uint16_t a, uint8_t v) override {
    if (eeprom_write_limit >= 0 && eeprom_writes >= eeprom_write_limit) return;
    ++eeprom_writes;
    eeprom[a] = v;
  }
  void request_reset() override { reset = true; }
  uint16_t free_stack() override { return 321; }
  uint8_t reset_cause() override { return 1; }
};

// A model that adds 1 to each input and reports saturation when an input is 30000.
struct FakeModel : dev::ModelPort {
  bool loaded = true;
  int resets = 0, steps = 0, begins = 0;
  uint8_t begin(uint16_t, uint16_t, uint8_t, int16_t*) override {
    ++begins;
    return r::OK;
  }
  uint8_t chunk(uint16_t off, const uint8_t*, uint8_t, int16_t* detail) override {
    if (off != 0) {
      *detail = 0;
      return r::BAD_STATE;
    }
    return r::OK;
  }
  uint8_t commit(int16_t*) override { return r::OK; }
  uint8_t erase() override { return r::OK; }
  uint8_t read(uint16_t, uint8_t n, uint8_t* dst) override {
    for (uint8_t i = 0; i < n; ++i) dst[i] = i;
    return r::OK;
  }
  void info(proto::ModelInfoReply* o) override { memset(o, 0, sizeof *o); }
  uint8_t status() override { return loaded ? 1 : 0; }
  uint16_t crc() override { return 0xBEEF; }
  bool flash_store() override { return false; }
  bool estimator_loaded() override { return loaded; }
  void estimator_reset() override { ++resets; }
  uint8_t estimator_step(const int16_t in[3], int16_t out[3]) override {
    ++steps;
    uint8_t fl = 0;
    for (int i = 0; i < 3; ++i) {
      out[i] = (int16_t)(in[i] + 1);
      if (in[i] == 30000) fl = 1;
    }
    return fl;
  }
};

struct Frame {
  uint8_t type, seq;
  std::vector<uint8_t> payload;
};

struct Rig {
  FakeHal hal;
  FakeModel model;
  dev::Device dev{hal, model};
  proto::FrameDecoder host_decoder;
  size_t tx_seen = 0;

  Rig() {
    hal.adc_counts[0] = hal.adc_counts[1] = hal.adc_counts[2] = 20000;  // R = R0 = 1 kOhm
  }
  void boot() { dev.begin(); }
  void send(uint8_t type, uint8_t seq, const uint8_t* p, uint8_t len) {
    uint8_t buf[proto::kMaxFrameLen];
    const uint8_t n = proto::encode_frame(type, seq, p, len, buf);
    hal.rx.insert(hal.rx.end(), buf, buf + n);
    dev.poll();
  }
  template <class M>
  void send_msg(const M& m, uint8_t seq) {
    uint8_t buf[proto::kMaxPayload];
    send(M::kType, seq, buf, m.encode(buf));
  }
  // SET_OUTPUTS as the host client sends it: the session of the latest HELLO_REPLY (a HELLO
  // of sequence number kHelloSeq is sent first when there was none; its reply is hidden) and
  // the next counter. A message with a non-zero counter is sent as it is.
  static constexpr uint8_t kHelloSeq = 0xF0;
  uint16_t out_counter = 0;
  bool latest_session(uint16_t* session) const {
    proto::FrameDecoder d;
    bool found = false;
    for (uint8_t b : hal.tx) {
      if (!d.feed(b) || d.type() != proto::msg::HELLO_REPLY) continue;
      proto::HelloReply h;
      if (h.decode(d.payload(), d.length())) *session = h.session, found = true;
    }
    return found;
  }
  void send_msg(const proto::SetOutputs& m0, uint8_t seq) {
    proto::SetOutputs m = m0;
    if (m.counter == 0) {
      if (!latest_session(&m.session)) {
        send(proto::msg::HELLO, kHelloSeq, nullptr, 0);
        latest_session(&m.session);
      }
      m.counter = ++out_counter;
    }
    uint8_t buf[proto::kMaxPayload];
    send(proto::SetOutputs::kType, seq, buf, m.encode(buf));
  }
  std::vector<Frame> received() {
    std::vector<Frame> out;
    for (; tx_seen < hal.tx.size(); ++tx_seen) {
      if (host_decoder.feed(hal.tx[tx_seen])) {
        Frame fr;
        fr.type = host_decoder.type();
        fr.seq = host_decoder.seq();
        fr.payload.assign(host_decoder.payload(), host_decoder.payload() + host_decoder.length());
        if (fr.type == proto::msg::HELLO_REPLY && fr.seq == kHelloSeq) continue;  // the rig's own
        out.push_back(fr);
      }
    }
    return out;
  }
  Frame one() {
    std::vector<Frame> fs = received();
    CHECK(fs.size() == 1);
    return fs.empty() ? Frame{0, 0, {}} : fs[0];
  }
};

proto::SetOutputs outputs(int16_t sp, uint8_t pumps, uint8_t valves) {
  proto::SetOutputs s;
  s.setpoint_dkpa[0] = s.setpoint_dkpa[1] = s.setpoint_dkpa[2] = sp;
  s.pump_mask = pumps;
  s.valve_mask = valves;
  s.session = 0;
  s.counter = 0;  // filled in by Rig::send_msg
  return s;
}

uint8_t nak_code(const Frame& fr) { return fr.type == proto::msg::NAK ? fr.payload[1] : 0xFF; }
int16_t nak_detail(const Frame& fr) { return proto::get_i16(fr.payload.data() + 2); }

// ---------------------------------------------------------------- tests

void test_boot_outputs_off() {
  Rig rig;
  rig.boot();
  CHECK(rig.hal.apply_calls >= 1);
  CHECK(rig.hal.out.pump_mask == 0 && rig.hal.out.valve_mask == 0);
  CHECK((rig.dev.flags() & f::CONFIG_DEFAULTS) != 0);  // blank EEPROM
  CHECK((rig.dev.flags() & f::R0_UNCALIBRATED) == 0);  // R0 taken from the first samples
  CHECK(rig.dev.config().r0_mohm[0] == 1000000);       // 20000 counts at 125 uV = 2.5 V
}

void test_duplicate_is_not_executed_twice() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(0, 0, 0), 6);  // the session handshake happens here
  rig.received();
  const int before = rig.hal.apply_calls;
  const size_t start = rig.hal.tx.size();
  rig.send_msg(outputs(-100, 1, 1), 7);
  const std::vector<uint8_t> first(rig.hal.tx.begin() + (long)start, rig.hal.tx.end());
  Frame a = rig.one();
  CHECK(a.type == proto::msg::ACK && a.seq == 7 && a.payload[0] == proto::msg::SET_OUTPUTS);
  CHECK(rig.hal.apply_calls == before + 1);
  const size_t tx_before = rig.hal.tx.size();
  rig.send_msg(outputs(-100, 1, 1), 7);  // the host's retry
  Frame b = rig.one();
  CHECK(b.type == a.type && b.seq == a.seq && b.payload == a.payload);
  CHECK(rig.hal.apply_calls == before + 1);  // not executed again
  const std::vector<uint8_t> again(rig.hal.tx.begin() + (long)tx_before, rig.hal.tx.end());
  CHECK(again == first);  // the cached frame, byte for byte
  // Same sequence number, other type: a new command.
  proto::Ping ping;
  ping.nonce = 0x12345678;
  rig.send_msg(ping, 7);
  Frame c = rig.one();
  CHECK(c.type == proto::msg::PONG && proto::get_u32(c.payload.data()) == 0x12345678u);
  // A PING retry gets the cached PONG, with the original device time.
  rig.hal.now_us += 5000;
  rig.send_msg(ping, 7);
  Frame d = rig.one();
  CHECK(d.payload == c.payload);
  printf("duplicates: %d applies for 2 SET_OUTPUTS frames with one sequence number\n", rig.hal.apply_calls - before);
}

void test_output_limits() {
  Rig rig;
  rig.boot();
  const int before = rig.hal.apply_calls;
  rig.send_msg(outputs(-601, 1, 0), 1);  // below MIN_SETPOINT_DKPA = -600
  Frame a = rig.one();
  CHECK(nak_code(a) == r::OUT_OF_RANGE && nak_detail(a) == 0);
  rig.send_msg(outputs(5, 1, 0), 2);  // positive pressure
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE);
  rig.send_msg(outputs(-100, 0x08, 0), 3);
  Frame c = rig.one();
  CHECK(nak_code(c) == r::OUT_OF_RANGE && nak_detail(c) == 1);
  rig.send_msg(outputs(-100, 0, 0x10), 4);
  Frame d = rig.one();
  CHECK(nak_code(d) == r::OUT_OF_RANGE && nak_detail(d) == 2);
  CHECK(rig.hal.apply_calls == before);  // nothing was changed
  rig.send_msg(outputs(-600, 7, 7), 5);  // the limit itself is allowed
  CHECK(rig.one().type == proto::msg::ACK);
  CHECK(rig.hal.out.setpoint_dkpa[2] == -600 && rig.hal.out.pump_mask == 7);
  // Raising the limit through CONFIG_SET widens the accepted range.
  proto::ConfigSet cs;
  cs.key = proto::config::MIN_SETPOINT_DKPA;
  cs.value = -801;
  rig.send_msg(cs, 6);
  Frame e = rig.one();
  CHECK(nak_code(e) == r::OUT_OF_RANGE && nak_detail(e) == 1);
  cs.value = -800;
  rig.send_msg(cs, 7);
  CHECK(rig.one().type == proto::msg::ACK);
  rig.send_msg(outputs(-800, 1, 1), 8);
  CHECK(rig.one().type == proto::msg::ACK);
  cs.key = 99;
  rig.send_msg(cs, 9);
  CHECK(nak_code(rig.one()) == r::BAD_KEY);
  // Stream rate limits 10 Hz .. SAMPLE_RATE_HZ max: the highest rate sustained with every channel, the IMU
  // and the largest model (issue 19); anything faster is refused.
  proto::StartStream ss;
  ss.channel_mask = 0x1F;
  ss.rate_hz = 9;
  rig.send_msg(ss, 10);
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE);
  // The highest rate is SAMPLE_RATE_HZ's max of the catalogue (messages.toml), the one source.
  proto::config::KeyInfo rate_info;
  proto::config::key_info(proto::config::SAMPLE_RATE_HZ, &rate_info);
  const uint16_t max_hz = uint16_t(rate_info.max);
  ss.rate_hz = uint16_t(max_hz + 1);
  rig.send_msg(ss, 11);
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE);
  ss.rate_hz = max_hz;
  rig.send_msg(ss, 12);
  CHECK(rig.one().type == proto::msg::ACK && rig.dev.rate_hz() == max_hz);
  // Watchdog timeout limits 100..10000 ms.
  proto::SetWatchdog wd;
  wd.timeout_ms = 99;
  rig.send_msg(wd, 13);
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE);
}

void test_link_watchdog_cuts_outputs() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(-200, 7, 7), 1);
  rig.received();
  CHECK(rig.hal.out.pump_mask == 7);
  rig.hal.now_us = 900000;  // PING at 900 ms feeds the watchdog
  proto::Ping ping;
  ping.nonce = 1;
  rig.send_msg(ping, 2);
  rig.received();
  rig.hal.now_us = 1900000;  // exactly the timeout after the last frame: still on
  rig.dev.poll();
  CHECK(rig.hal.out.pump_mask == 7);
  rig.hal.now_us = 1901000;  // 1001 ms of silence
  rig.dev.poll();
  CHECK(rig.hal.out.pump_mask == 0 && rig.hal.out.valve_mask == 0);
  CHECK(rig.hal.out.setpoint_dkpa[0] == 0);
  CHECK((rig.dev.flags() & f::WATCHDOG_TRIPPED) != 0);
  CHECK((rig.dev.flags() & f::OUTPUTS_ACTIVE) == 0);
  CHECK(rig.dev.counters().watchdog_trips == 1);
  Frame e = rig.one();
  CHECK(e.type == proto::msg::ERROR && proto::get_i16(e.payload.data() + 1) == f::WATCHDOG_TRIPPED);
  rig.hal.now_us = 5000000;  // no second trip while the outputs are off
  rig.dev.poll();
  CHECK(rig.dev.counters().watchdog_trips == 1);
  // The next SET_OUTPUTS clears the flag; idle outputs never trip.
  rig.send_msg(outputs(0, 0, 0), 3);
  rig.received();
  CHECK((rig.dev.flags() & f::WATCHDOG_TRIPPED) == 0);
  rig.hal.now_us = 60000000;
  rig.dev.poll();
  CHECK(rig.dev.counters().watchdog_trips == 1);
  // A shorter timeout set by command.
  proto::SetWatchdog wd;
  wd.timeout_ms = 100;
  rig.send_msg(wd, 4);
  rig.send_msg(outputs(-50, 1, 0), 5);
  rig.received();
  rig.hal.now_us += 101000;
  rig.dev.poll();
  CHECK(rig.hal.out.pump_mask == 0 && rig.dev.counters().watchdog_trips == 2);
  printf("link watchdog: outputs cut after 1001 ms of silence (timeout 1000 ms), trips=%u\n",
         rig.dev.counters().watchdog_trips);
}

std::vector<proto::Sample> samples_of(const std::vector<Frame>& fs) {
  std::vector<proto::Sample> out;
  for (const Frame& fr : fs) {
    if (fr.type != proto::msg::SAMPLE) continue;
    proto::Sample s;
    CHECK(s.decode(fr.payload.data(), (uint8_t)fr.payload.size()));
    out.push_back(s);
  }
  return out;
}

void test_sampling_and_overruns() {
  Rig rig;
  rig.boot();
  proto::StartStream ss;
  ss.rate_hz = 100;
  ss.channel_mask = 0x1F;
  rig.send_msg(ss, 1);
  rig.received();
  CHECK(rig.dev.streaming() && rig.model.resets == 1);
  rig.dev.on_sample_ticks(1, 10000);
  rig.dev.on_sample_ticks(3, 40000);  // two ticks were missed
  rig.dev.on_sample_ticks(1, 50000);
  std::vector<proto::Sample> s = samples_of(rig.received());
  CHECK(s.size() == 3);
  if (s.size() == 3) {
    CHECK(s[0].t_us == 10000 && s[1].t_us == 40000 && s[2].t_us == 50000);
    CHECK((s[0].status & f::OVERRUN) == 0);
    CHECK((s[1].status & f::OVERRUN) != 0);
    CHECK((s[2].status & f::OVERRUN) == 0);
    CHECK(s[0].dr_centi[0] == 0 && s[0].adc[1] == 20000);
    CHECK(s[0].euler_16[2] == 48 && s[0].estimate[0] == 1);  // fake model: input + 1
  }
  CHECK(rig.dev.counters().overruns == 2);
  // Overruns are reported by STATUS too.
  proto::Status st;
  rig.send_msg(st, 2);
  Frame fr = rig.one();
  proto::StatusReply rep;
  CHECK(fr.type == proto::msg::STATUS_REPLY && rep.decode(fr.payload.data(), (uint8_t)fr.payload.size()));
  CHECK(rep.overruns == 2 && rep.free_ram == 321 && rep.rx_frames == 2);
  // Channels outside the mask are zero; the estimator still gets every input.
  proto::StartStream only0;
  only0.rate_hz = 50;
  only0.channel_mask = proto::chan::ADC0 | proto::chan::ESTIMATES;
  rig.hal.adc_counts[1] = 13333;  // ~500 ohm
  rig.send_msg(only0, 3);
  rig.received();
  rig.dev.on_sample_ticks(1, 60000);
  s = samples_of(rig.received());
  CHECK(s.size() == 1);
  if (s.size() == 1) {
    CHECK(s[0].adc[1] == 0 && s[0].dr_centi[1] == 0 && s[0].euler_16[0] == 0);
    CHECK(s[0].estimate[1] == -5000 + 1);  // dR of channel 1 reached the estimator
  }
  // A full transmit buffer drops telemetry (counted) instead of blocking.
  rig.hal.tx_free = 10;
  rig.dev.on_sample_ticks(1, 70000);
  CHECK(rig.dev.counters().dropped_telemetry == 1);
  printf("sampling: 3 ticks taken at once -> overruns=%u, OVERRUN flag on that SAMPLE only\n",
         rig.dev.counters().overruns);
}

void test_sensor_faults_do_not_stall() {
  Rig rig;
  rig.boot();
  proto::StartStream ss;
  ss.rate_hz = 100;
  ss.channel_mask = 0x1F;
  rig.send_msg(ss, 1);
  rig.received();
  rig.hal.adc_ok = false;
  rig.hal.imu_ok = false;
  rig.hal.adc_reads = 0;
  for (int i = 0; i < 5; ++i) rig.dev.on_sample_ticks(1, (uint32_t)(i * 10000));
  std::vector<Frame> fs = rig.received();
  std::vector<proto::Sample> s = samples_of(fs);
  int errors = 0;
  for (const Frame& fr : fs) errors += fr.type == proto::msg::ERROR;
  CHECK(s.size() == 5);
  CHECK(errors == 1);             // reported once, when it happens
  CHECK(rig.hal.adc_reads == 5);  // one failed read per sample, not one per channel
  for (const proto::Sample& x : s) CHECK((x.status & (f::ADC_FAULT | f::IMU_FAULT)) == (f::ADC_FAULT | f::IMU_FAULT));
  CHECK(rig.dev.counters().sensor_faults == 5);
  CHECK(rig.model.steps == 0);  // no estimate from missing inputs
  // A channel lost in the middle of a sample keeps what was converted before it.
  rig.hal.adc_ok = true;
  rig.hal.imu_ok = true;
  rig.hal.adc_dead_channel = 1;
  rig.dev.on_sample_ticks(1, 60000);
  s = samples_of(rig.received());
  CHECK(s.size() == 1);
  if (s.size() == 1) {
    CHECK(s[0].adc[0] == 20000 && s[0].adc[1] == 0 && s[0].adc[2] == 0);
    CHECK((s[0].status & f::ADC_FAULT) != 0 && (s[0].status & f::IMU_FAULT) == 0);
  }
  CHECK(rig.model.steps == 0);
}

void test_dr_math() {
  // Divider: V = 5 R / (R + 1000). 20000 counts at 125 uV = 2.5 V -> 1000 ohm.
  CHECK(dev::counts_to_mohm(20000 * 16, 16, 1) == 1000000);
  CHECK(dev::counts_to_dr_centi(20000, 1, 1000000) == 0);
  // Against the divider formula in double, for every PGA code and R0 from 1 ohm to 100 kOhm:
  // the integer chain (R rounded to the milliohm, then dR rounded) stays within 0.5 step of
  // the exact dR of the same count plus the rounding of R (0.5 mohm of R0).
  const double fs[6] = {6.144, 4.096, 2.048, 1.024, 0.512, 0.256};
  const int32_t r0s[] = {1000, 9999, 150000, 1000000, 1234567, 47000000, 100000000};
  double worst = 0;
  uint32_t seed = 12345;
  for (uint8_t pga = 0; pga < 6; ++pga) {
    for (int32_t r0 : r0s) {
      for (int i = 0; i < 400; ++i) {
        seed = seed * 1103515245u + 12345u;
        const int16_t counts = (int16_t)((seed >> 8) % 32768);
        const double v = counts * fs[pga] / 32768.0;
        if (v <= 0 || v >= 5.0) continue;
        const double r_mohm = 1e6 * v / (5.0 - v);
        const double want = (r_mohm - r0) / r0 * 1e4;
        const int16_t got = dev::counts_to_dr_centi(counts, pga, r0);
        if (want >= 32767.5) {
          CHECK(got == 32767);
          continue;
        }
        const double err = fabs(got - want) / (0.5 + 0.5e4 / r0 + 1e-6);
        if (err > worst) worst = err;
        CHECK(err <= 1.0);
      }
    }
  }
  CHECK(dev::counts_to_dr_centi(0, 1, 1000000) == -10000);     // short: -100 %
  CHECK(dev::counts_to_dr_centi(32767, 1, 1000000) == 32767);  // above 5 V: saturated
  CHECK(dev::counts_to_dr_centi(-5, 1, 1000000) == -10000);
  CHECK(dev::counts_to_dr_centi(123, 1, 0) == 0);               // no R0
  CHECK(dev::divider_b(0) == 80000 && dev::divider_a(0) == 3);  // 6.144 V: 3/16000 V per count
  CHECK(dev::divider_b(5) == 640000 && dev::divider_b(9) == 640000);
  CHECK(dev::counts_to_mohm(-3, 1, 1) == 0 && dev::counts_to_mohm(40000, 1, 1) == 0x7FFFFFFF);
  printf("dR: worst error %.2f of the rounding bound over 6 PGA codes, R0 1 ohm..100 kOhm\n", worst);
}

// Conversions between float32 bits and scaled integers (no float code on the AVR), against
// the host's float arithmetic over random values.
void test_f32_bits() {
  uint32_t seed = 777;
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    seed = seed * 1103515245u + 12345u;
    const uint32_t hi = seed;
    seed = seed * 1103515245u + 12345u;
    // Random float32 between 1e-9 and 1e9 in magnitude, either sign.
    const float x = (float)((hi & 1 ? -1.0 : 1.0) * pow(10.0, -9.0 + 18.0 * (seed >> 8) / 16777216.0));
    uint32_t bits;
    memcpy(&bits, &x, 4);
    const int32_t factor = (int32_t)((hi >> 8) % 65536) - 32768;
    const long double exact = (long double)x * factor;
    int32_t got;
    const bool ok = dev::f32_scaled(bits, factor, 2000000000, &got);
    if (fabsl(exact) > 2.0e9L) {
      CHECK(!ok && got == (exact > 0 ? 2000000000 : -2000000000));
    } else {
      const long double r = exact >= 0 ? floorl(exact + 0.5L) : -floorl(-exact + 0.5L);
      if (!(ok && got == (int32_t)r)) printf("f32_scaled %.9g * %d: got %d want %.1Lf\n", x, factor, got, r);
      CHECK(ok && got == (int32_t)r);
      ++checked;
    }
  }
  CHECK(checked > 5000);
  int32_t v;
  const float nan = NAN, inf = INFINITY, r0 = 1234.5f;
  uint32_t b;
  memcpy(&b, &nan, 4);
  CHECK(!dev::f32_scaled(b, 1000, 100000000, &v) && v == 0);
  memcpy(&b, &inf, 4);
  CHECK(!dev::f32_scaled(b, 1000, 100000000, &v) && v == 100000000);
  memcpy(&b, &r0, 4);
  CHECK(dev::f32_scaled(b, 1000, 100000000, &v) && v == 1234500);
  // mohm -> ohm as float32: the nearest float (ties aside) over the R0 range.
  for (int i = 0; i < 20000; ++i) {
    seed = seed * 1103515245u + 12345u;
    const uint32_t mohm = 1000 + seed % 99999001u;
    const uint32_t fb = dev::f32_from_ratio(mohm, 1000);
    float f;
    memcpy(&f, &fb, 4);
    const float want = (float)(mohm / 1000.0);
    CHECK(f == want);
  }
}

void test_calibrate_and_set_r0() {
  Rig rig;
  rig.boot();
  rig.hal.adc_counts[0] = 13333;  // ~500 ohm
  proto::CalibrateR0 c;
  c.n_samples = 8;
  c.channel_mask = 1;
  rig.send_msg(c, 1);
  Frame fr = rig.one();
  proto::R0Reply rep;
  CHECK(fr.type == proto::msg::R0_REPLY && rep.decode(fr.payload.data(), (uint8_t)fr.payload.size()));
  CHECK(fabsf(rep.r0_ohm[0] - 500.0f) < 0.1f && fabsf(rep.r0_ohm[1] - 1000.0f) < 0.01f);
  c.n_samples = 65;
  rig.send_msg(c, 2);
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE);
  rig.hal.adc_ok = false;
  c.n_samples = 4;
  rig.send_msg(c, 3);
  CHECK(nak_code(rig.one()) == r::SENSOR_FAULT);
  proto::SetR0 s;
  s.channel_mask = 4;
  s.r0_ohm[0] = s.r0_ohm[1] = 0;
  s.r0_ohm[2] = 1234.5f;
  rig.send_msg(s, 4);
  CHECK(rig.one().type == proto::msg::ACK && rig.dev.config().r0_mohm[2] == 1234500);
  s.r0_ohm[2] = NAN;
  rig.send_msg(s, 5);
  CHECK(nak_code(rig.one()) == r::OUT_OF_RANGE && rig.dev.config().r0_mohm[2] == 1234500);
}

void test_other_commands() {
  Rig rig;
  rig.boot();
  proto::Hello h;
  rig.send_msg(h, 1);
  Frame fr = rig.one();
  proto::HelloReply hr;
  CHECK(fr.type == proto::msg::HELLO_REPLY && hr.decode(fr.payload.data(), (uint8_t)fr.payload.size()));
  CHECK(hr.proto_major == proto::kVersionMajor && hr.n_channels == 3 && hr.model_crc == 0xBEEF);
  CHECK((hr.capabilities & (proto::cap::ADC | proto::cap::IMU | proto::cap::ESTIMATOR)) ==
        (proto::cap::ADC | proto::cap::IMU | proto::cap::ESTIMATOR));
  // HELLO with a payload (a later release) and another major version is still answered.
  const uint8_t extra[3] = {1, 2, 3};
  uint8_t frame[proto::kMaxFrameLen];
  const uint8_t fl = proto::encode_frame(proto::msg::HELLO, 40, extra, 3, frame, (proto::kVersionMajor % 15 + 1) << 4);
  rig.hal.rx.insert(rig.hal.rx.end(), frame, frame + fl);
  rig.dev.poll();
  fr = rig.one();
  CHECK(fr.type == proto::msg::HELLO_REPLY && fr.seq == 40 && fr.payload[0] == proto::kVersionMajor);
  // A device-to-host type sent to the device.
  proto::Ack a;
  a.acked_type = 1;
  rig.send_msg(a, 2);
  CHECK(nak_code(rig.one()) == r::UNKNOWN_TYPE);
  // REPLAY: 2 samples, estimates interleaved like the inputs; the length must be 3 per sample.
  uint8_t p[1 + 12];
  p[0] = 1;
  for (int i = 0; i < 6; ++i) proto::put_i16(p + 1 + 2 * i, (int16_t)(100 * i));
  rig.send(proto::msg::REPLAY, 3, p, sizeof p);
  fr = rig.one();
  CHECK(fr.type == proto::msg::REPLAY_RESULT && fr.payload.size() == 13);
  if (fr.payload.size() == 13) CHECK(proto::get_i16(fr.payload.data() + 1 + 2 * 5) == 501);
  rig.send(proto::msg::REPLAY, 4, p, 1 + 4);
  CHECK(nak_code(rig.one()) == r::BAD_LENGTH);
  rig.send(proto::msg::REPLAY, 40, p, 2);  // half an int16
  CHECK(nak_code(rig.one()) == r::BAD_LENGTH);
  rig.send(proto::msg::REPLAY, 41, p, 1);  // no samples: an empty result
  fr = rig.one();
  CHECK(fr.type == proto::msg::REPLAY_RESULT && fr.payload.size() == 1);
  // Model writes are refused while streaming.
  proto::StartStream ss;
  ss.rate_hz = 50;
  ss.channel_mask = 1;
  rig.send_msg(ss, 5);
  rig.received();
  proto::ModelBegin mb;
  mb.length = 100;
  mb.crc = 0;
  mb.format_version = 1;
  rig.send_msg(mb, 6);
  CHECK(nak_code(rig.one()) == r::BUSY && rig.model.begins == 0);
  rig.send(proto::msg::REPLAY, 7, p, sizeof p);
  CHECK(nak_code(rig.one()) == r::BUSY);
  proto::StopStream stop;
  rig.send_msg(stop, 8);
  rig.received();
  rig.send_msg(mb, 9);
  CHECK(rig.one().type == proto::msg::ACK && rig.model.begins == 1);
  // Chunk errors carry the store's code and detail.
  uint8_t chunk[4] = {5, 0, 1, 2};
  rig.send(proto::msg::MODEL_CHUNK, 10, chunk, sizeof chunk);
  CHECK(nak_code(rig.one()) == r::BAD_STATE);
  // CONFIG_GET of a default.
  proto::ConfigGet g;
  g.key = proto::config::WATCHDOG_MS;
  rig.send_msg(g, 11);
  fr = rig.one();
  CHECK(fr.type == proto::msg::CONFIG_VALUE && proto::get_i32(fr.payload.data() + 1) == 1000);
  // RESET acknowledges first, then asks the board for the reset.
  proto::Reset rs;
  rig.send_msg(rs, 12);
  CHECK(rig.one().type == proto::msg::ACK && rig.hal.reset);
}

void test_config_store() {
  FakeHal hal;
  dev::ConfigStore store(hal);
  dev::Config c;
  CHECK(!store.load(&c));  // blank EEPROM -> defaults
  CHECK(c.sample_rate_hz == 50 && c.watchdog_ms == 1000 && c.min_setpoint_dkpa == -600);
  c.set(proto::config::SAMPLE_RATE_HZ, 100);  // any legal rate but the default
  c.set(proto::config::R0_CH1_MOHM, 2345678);
  c.set(proto::config::PWM_SCALE_MILLI, -123456);
  c.set(proto::config::AUTOSTART, 1);
  store.save(c);
  dev::Config d;
  dev::ConfigStore store2(hal);
  CHECK(store2.load(&d));
  int32_t v = 0;
  CHECK(d.get(proto::config::SAMPLE_RATE_HZ, &v) && v == 100);
  CHECK(d.get(proto::config::R0_CH1_MOHM, &v) && v == 2345678);
  CHECK(d.get(proto::config::PWM_SCALE_MILLI, &v) && v == -123456);
  CHECK(d.get(proto::config::AUTOSTART, &v) && v == 1);
  // Torn writes: a power cut after k bytes of the next save leaves the previous config.
  int torn_ok = 0, torn_total = 0;
  for (int k = 0; k < (int)dev::kConfigSlotSize + 2; ++k) {
    FakeHal h2;
    memcpy(h2.eeprom, hal.eeprom, sizeof h2.eeprom);
    dev::ConfigStore s3(h2);
    dev::Config e;
    s3.load(&e);
    e.set(proto::config::SAMPLE_RATE_HZ, 77);
    h2.eeprom_write_limit = k;
    s3.save(e);
    dev::ConfigStore s4(h2);
    dev::Config got;
    ++torn_total;
    if (s4.load(&got) && (got.sample_rate_hz == 100 || got.sample_rate_hz == 77)) ++torn_ok;
  }
  CHECK(torn_ok == torn_total);
  // A corrupt newest slot falls back to the older one; both corrupt -> defaults.
  dev::Config e2 = d;
  e2.set(proto::config::SAMPLE_RATE_HZ, 99);
  store2.save(e2);  // now slots hold 100 (old) and 99 (new)
  FakeHal h3;
  memcpy(h3.eeprom, hal.eeprom, sizeof h3.eeprom);
  dev::ConfigStore s5(h3);
  dev::Config got;
  CHECK(s5.load(&got) && got.sample_rate_hz == 99);
  for (uint16_t slot = 0; slot < 2; ++slot) {
    uint8_t* rate = h3.eeprom + slot * dev::kConfigSlotSize + 2;
    if (*rate == 99) *rate ^= 0x40;  // flip a bit of the newest slot's rate byte
  }
  dev::ConfigStore s6(h3);
  CHECK(s6.load(&got) && got.sample_rate_hz == 100);
  for (int i = 0; i < 64; ++i) h3.eeprom[i] ^= 0x5A;
  dev::ConfigStore s7(h3);
  CHECK(!s7.load(&got) && got.sample_rate_hz == 50);
  // A device booting on a corrupt block runs on defaults with CONFIG_DEFAULTS set.
  Rig rig;
  memcpy(rig.hal.eeprom, h3.eeprom, 64);
  rig.boot();
  CHECK((rig.dev.flags() & f::CONFIG_DEFAULTS) != 0 && rig.dev.config().watchdog_ms == 1000);
  printf("config store: %d/%d torn saves left a valid configuration\n", torn_ok, torn_total);
}

void test_boot_counter_and_autostart() {
  Rig rig;
  dev::ConfigStore store(rig.hal);
  dev::Config c;
  c.set_defaults();
  c.set(proto::config::AUTOSTART, 1);
  c.set(proto::config::R0_MODE, 1);
  c.set(proto::config::R0_CH0_MOHM, 1500000);
  c.boots = 4;
  store.save(c);
  rig.boot();
  CHECK(rig.dev.streaming() && rig.dev.rate_hz() == 50);
  CHECK((rig.dev.flags() & f::STANDALONE) != 0);
  CHECK((rig.dev.flags() & (f::CONFIG_DEFAULTS | f::R0_UNCALIBRATED)) == 0);
  CHECK(rig.dev.config().r0_mohm[0] == 1500000);  // restored, not recalibrated
  CHECK(rig.dev.config().boots == 5);
}

void test_rate_divider_and_watchdog_logic() {
  dev::RateDivider d;
  const uint16_t rates[] = {10, 30, 50, 100, 133, 200};
  for (uint16_t rate : rates) {
    d.set_rate(rate);
    int ticks = 0, last = -1, min_gap = 100000, max_gap = 0;
    for (int t = 0; t < 10000; ++t) {  // 10 s of 1 kHz ticks
      if (d.tick()) {
        if (last >= 0) {
          if (t - last < min_gap) min_gap = t - last;
          if (t - last > max_gap) max_gap = t - last;
        }
        last = t;
        ++ticks;
      }
    }
    CHECK(ticks == rate * 10);
    CHECK(max_gap - min_gap <= 1);
  }
  d.set_rate(0);
  CHECK(!d.tick());
  dev::LinkWatchdog w;
  w.set_timeout(500);
  w.feed(0xFFFFFF00u);  // across the millis() wrap
  CHECK(!w.expired(0xFFFFFF00u + 500, true));
  CHECK(w.expired(0xFFFFFF00u + 501, true));
  CHECK(!w.expired(0xFFFFFF00u + 501, false));
}

void test_sequence_rules() {
  Rig rig;
  rig.boot();
  // HELLO is never a duplicate and clears the cache.
  proto::Hello h;
  rig.send_msg(h, 3);
  Frame a = rig.one();
  rig.hal.now_us += 7000;
  rig.send_msg(h, 3);
  Frame b = rig.one();
  CHECK(a.type == proto::msg::HELLO_REPLY && b.type == proto::msg::HELLO_REPLY);
  CHECK(proto::get_u32(a.payload.data() + 12) + 7 == proto::get_u32(b.payload.data() + 12));
  const int applies = rig.hal.apply_calls;
  rig.send_msg(outputs(-10, 1, 0), 9);
  rig.send_msg(h, 10);
  rig.send_msg(outputs(-10, 1, 0), 9);  // same seq and type as before HELLO: a new command
  rig.received();
  CHECK(rig.hal.apply_calls == applies + 2);
  // SAMPLE frames count from 0 at each START_STREAM; ERROR frames have their own counter.
  proto::StartStream ss;
  ss.rate_hz = 100;
  ss.channel_mask = 0x07;
  rig.send_msg(ss, 11);
  rig.received();
  rig.dev.on_sample_ticks(1, 1000);
  rig.dev.on_sample_ticks(1, 2000);
  rig.hal.adc_ok = false;
  rig.dev.on_sample_ticks(1, 3000);
  std::vector<Frame> fs = rig.received();
  std::vector<uint8_t> sample_seqs, error_seqs;
  for (const Frame& fr : fs) {
    if (fr.type == proto::msg::SAMPLE) sample_seqs.push_back(fr.seq);
    if (fr.type == proto::msg::ERROR) error_seqs.push_back(fr.seq);
  }
  CHECK((sample_seqs == std::vector<uint8_t>{0, 1, 2}));
  CHECK((error_seqs == std::vector<uint8_t>{0}));
  rig.hal.adc_ok = true;
  ss.channel_mask = 0x01;
  rig.send_msg(ss, 12);
  rig.received();
  rig.dev.on_sample_ticks(1, 4000);
  fs = rig.received();
  CHECK(fs.size() == 1 && fs[0].type == proto::msg::SAMPLE && fs[0].seq == 0);
}

// Issue 19, item 1: only a valid host command feeds the link watchdog. The board's own frames
// echoed back (TX-RX loopback) and malformed commands keep nothing alive.
void test_watchdog_fed_only_by_host_commands() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(-200, 7, 7), 1);
  rig.received();
  CHECK(rig.hal.out.pump_mask == 7);
  const uint32_t t_on = rig.hal.now_us;
  // Every 100 ms: an echo of each device-to-host frame the board sends, and a PING with a
  // bad length (a known type, so it reaches the handler, but not a valid command).
  int echoes = 0;
  uint8_t seq = 2;
  for (uint32_t t = 100000; t <= 1500000 && rig.hal.out.pump_mask; t += 100000) {
    rig.hal.now_us = t_on + t;
    proto::Ack a;
    a.acked_type = proto::msg::SET_OUTPUTS;
    rig.send_msg(a, seq);
    proto::Sample smp = proto::Sample();
    rig.send_msg(smp, seq);
    proto::HelloReply hr = proto::HelloReply();
    rig.send_msg(hr, seq);
    const uint8_t short_ping[2] = {1, 2};
    rig.send(proto::msg::PING, (uint8_t)(seq + 1), short_ping, 2);
    seq = (uint8_t)(seq + 2);
    echoes += 3;
    rig.received();
  }
  const uint32_t cut_ms = (rig.hal.now_us - t_on) / 1000;
  printf("loopback: outputs cut %u ms after the last command despite %d echoed frames\n", cut_ms, echoes);
  CHECK(rig.hal.out.pump_mask == 0 && rig.hal.out.valve_mask == 0);
  CHECK(cut_ms > 1000 && cut_ms <= 1100);  // the first poll after the 1000 ms timeout
  CHECK(rig.dev.counters().watchdog_trips == 1);
}

// Issue 19, item 1: the watchdog also runs from poll_rx(), which drivers call while they wait
// (ADC conversions, EEPROM writes): a long wait cannot hold the outputs; the ERROR report
// follows at the next poll().
void test_watchdog_runs_inside_driver_waits() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(-200, 7, 7), 1);
  rig.received();
  rig.hal.now_us += 1001000;
  rig.dev.poll_rx();  // as from an ADC wait loop
  CHECK(rig.hal.out.pump_mask == 0 && rig.dev.counters().watchdog_trips == 1);
  CHECK(rig.received().empty());  // nothing sent from inside the wait
  rig.dev.poll();
  Frame e = rig.one();
  CHECK(e.type == proto::msg::ERROR && proto::get_i16(e.payload.data() + 1) == f::WATCHDOG_TRIPPED);
}

// Issue 19, item 1: operations that block (R0 calibration, EEPROM writes) are refused while
// an output is on, so nothing holds the outputs past the link watchdog.
void test_blocking_commands_refused_while_outputs_on() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(-100, 1, 0), 1);
  rig.received();
  const int reads = rig.hal.adc_reads, writes = rig.hal.eeprom_writes, begins = rig.model.begins;
  const uint8_t cal[2] = {64, 7};
  rig.send(proto::msg::CALIBRATE_R0, 2, cal, 2);
  CHECK(nak_code(rig.one()) == r::BUSY);
  uint8_t begin[5] = {100, 0, 0x34, 0x12, 1};
  rig.send(proto::msg::MODEL_BEGIN, 3, begin, 5);
  CHECK(nak_code(rig.one()) == r::BUSY);
  uint8_t chunk[10] = {0, 0, 1, 2, 3, 4, 5, 6, 7, 8};
  rig.send(proto::msg::MODEL_CHUNK, 4, chunk, 10);
  CHECK(nak_code(rig.one()) == r::BUSY);
  rig.send(proto::msg::MODEL_COMMIT, 5, nullptr, 0);
  CHECK(nak_code(rig.one()) == r::BUSY);
  rig.send(proto::msg::MODEL_ERASE, 6, nullptr, 0);
  CHECK(nak_code(rig.one()) == r::BUSY);
  rig.send(proto::msg::CONFIG_SAVE, 7, nullptr, 0);
  CHECK(nak_code(rig.one()) == r::BUSY);
  rig.send(proto::msg::CONFIG_RESET, 8, nullptr, 0);
  CHECK(nak_code(rig.one()) == r::BUSY);
  CHECK(rig.hal.adc_reads == reads && rig.hal.eeprom_writes == writes && rig.model.begins == begins);
  CHECK(rig.hal.out.pump_mask == 1);  // refused, not switched off
  // With the outputs off, the same commands run.
  rig.send_msg(outputs(0, 0, 0), 9);
  rig.received();
  rig.send(proto::msg::CALIBRATE_R0, 10, cal, 2);
  CHECK(rig.one().type == proto::msg::R0_REPLY);
  rig.send(proto::msg::MODEL_BEGIN, 11, begin, 5);
  CHECK(rig.one().type == proto::msg::ACK && rig.model.begins == begins + 1);
  rig.send(proto::msg::CONFIG_SAVE, 12, nullptr, 0);
  CHECK(rig.one().type == proto::msg::ACK && rig.hal.eeprom_writes > writes);
}

// Issue 19, item 4: a replayed old SET_OUTPUTS cannot turn outputs back on, in its own
// session or after a new HELLO; all off is accepted whatever its age.
void test_replayed_set_outputs_refused() {
  Rig rig;
  rig.boot();
  rig.send_msg(outputs(-300, 7, 7), 1);  // counter 1: on
  rig.received();
  uint16_t session = 0;
  CHECK(rig.latest_session(&session));
  proto::SetOutputs on = outputs(-300, 7, 7);
  on.session = session;
  on.counter = 1;
  rig.send_msg(outputs(0, 0, 0), 2);  // counter 2: off
  rig.received();
  CHECK(rig.hal.out.pump_mask == 0);
  // The old "on" frame arrives again, under a new sequence number and under its own.
  rig.send_msg(on, 3);
  Frame a = rig.one();
  CHECK(nak_code(a) == r::BAD_STATE && nak_detail(a) == 3);
  rig.send_msg(on, 1);
  CHECK(nak_code(rig.one()) == r::BAD_STATE);
  CHECK(rig.hal.out.pump_mask == 0 && rig.hal.out.valve_mask == 0);
  // A newer counter of the same session is accepted; counters may skip (lost frames).
  on.counter = 40;
  rig.send_msg(on, 4);
  CHECK(rig.one().type == proto::msg::ACK && rig.hal.out.pump_mask == 7);
  on.counter = 39;
  rig.send_msg(on, 5);
  CHECK(nak_code(rig.one()) == r::BAD_STATE);
  // An off without any session is accepted (safe at any age).
  proto::SetOutputs off = outputs(0, 0, 0);
  off.counter = 0xFFFF;
  off.session = (uint16_t)(session + 1);
  rig.send_msg(off, 6);
  CHECK(rig.one().type == proto::msg::ACK && rig.hal.out.pump_mask == 0);
  // A new HELLO starts a new session: frames of the old one are refused.
  proto::Hello h;
  rig.send_msg(h, 7);
  Frame hr = rig.one();
  proto::HelloReply reply;
  CHECK(hr.type == proto::msg::HELLO_REPLY && reply.decode(hr.payload.data(), (uint8_t)hr.payload.size()));
  CHECK(reply.session != session);
  on.counter = 41;
  rig.send_msg(on, 8);
  CHECK(nak_code(rig.one()) == r::BAD_STATE && rig.hal.out.pump_mask == 0);
  on.session = reply.session;
  on.counter = 1;
  rig.send_msg(on, 9);
  CHECK(rig.one().type == proto::msg::ACK && rig.hal.out.pump_mask == 7);
  // A retried HELLO (same sequence number, its first reply late) keeps the session the host
  // may already hold; the next HELLO does not.
  rig.hal.now_us += 3000;
  rig.send_msg(h, 20);
  Frame h1 = rig.one();
  rig.hal.now_us += 250000;
  rig.send_msg(h, 20);
  Frame h2 = rig.one();
  rig.send_msg(h, 21);
  Frame h3 = rig.one();
  proto::HelloReply r1, r2, r3;
  CHECK(r1.decode(h1.payload.data(), (uint8_t)h1.payload.size()) &&
        r2.decode(h2.payload.data(), (uint8_t)h2.payload.size()) &&
        r3.decode(h3.payload.data(), (uint8_t)h3.payload.size()));
  CHECK(r1.session == r2.session && r3.session != r2.session && r1.session != reply.session);
  printf("replay: an old 'on' frame refused in its session and after a new HELLO (session %04x -> %04x)\n", session,
         reply.session);
}

// Issue 19, item 3: skipped sample ticks take their SAMPLE sequence numbers, so the host
// counts them as lost samples.
void test_skipped_ticks_leave_a_sequence_gap() {
  Rig rig;
  rig.boot();
  proto::StartStream ss;
  ss.rate_hz = 100;
  ss.channel_mask = 0x07;
  rig.send_msg(ss, 1);
  rig.received();
  rig.dev.on_sample_ticks(1, 10000);
  rig.dev.on_sample_ticks(4, 50000);  // three ticks were skipped
  rig.dev.on_sample_ticks(1, 60000);
  std::vector<uint8_t> seqs;
  for (const Frame& fr : rig.received())
    if (fr.type == proto::msg::SAMPLE) seqs.push_back(fr.seq);
  CHECK((seqs == std::vector<uint8_t>{0, 4, 5}));
  CHECK(rig.dev.counters().overruns == 3);
}

int main() {
  test_boot_outputs_off();
  test_duplicate_is_not_executed_twice();
  test_output_limits();
  test_link_watchdog_cuts_outputs();
  test_sampling_and_overruns();
  test_sensor_faults_do_not_stall();
  test_dr_math();
  test_f32_bits();
  test_calibrate_and_set_r0();
  test_other_commands();
  test_sequence_rules();
  test_config_store();
  test_boot_counter_and_autostart();
  test_rate_divider_and_watchdog_logic();
  test_watchdog_fed_only_by_host_commands();
  test_blocking_commands_refused_while_outputs_on();
  test_watchdog_runs_inside_driver_waits();
  test_replayed_set_outputs_refused();
  test_skipped_ticks_leave_a_sequence_gap();
  printf("test_device: %d checks, %d failures\n", g_checks, g_failures);
  return g_failures ? 1 : 0;
}
