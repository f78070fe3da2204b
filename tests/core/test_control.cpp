// Host tests of the strain controller (control.h), its EEPROM store (control_store.h) and its
// safety inside dev::Device: PI step on a plant stub, anti-windup, slew, output limits, vent on
// watchdog / sensor fault / estimator saturation, trajectory CRC and torn writes, the gains'
// fixed-point bytes round trip. Plant parameters come from a fixed-seed generator with wide
// ranges; bounds are stated with each check.
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <random>
#include <vector>

#include "check.h"
#include "control.h"
#include "control_store.h"
#include "device.h"
#include "frame_codec.h"
#include "protocol_messages.h"

namespace r = proto::result;
namespace f = proto::flag;

struct FakeHal : dev::Hal {
  uint32_t now_us = 0;
  dev::Outputs out{};
  bool adc_ok = true;
  int adc_ch = -1;
  std::vector<uint8_t> rx, tx;
  size_t rx_pos = 0;
  uint8_t eeprom[1024];
  long writes = 0, write_limit = -1;  // >= 0: writes beyond it are lost (power cut)
  FakeHal() { memset(eeprom, 0xFF, sizeof eeprom); }
  uint32_t micros() override { return now_us; }
  uint32_t millis() override { return now_us / 1000; }
  void apply_outputs(const dev::Outputs& o) override { out = o; }
  bool adc_start(uint8_t ch) override { return adc_ok && (adc_ch = ch, true); }
  bool adc_finish(int16_t* c) override { return adc_ok && adc_ch >= 0 && (*c = 20000, adc_ch = -1, true); }
  void adc_configure(uint8_t, uint8_t) override {}
  bool imu_read(int16_t*, uint8_t*) override { return false; }
  bool adc_present() override { return adc_ok; }
  bool imu_present() override { return false; }
  int16_t serial_read() override { return rx_pos < rx.size() ? rx[rx_pos++] : -1; }
  void serial_write(const uint8_t* d, uint8_t n) override { tx.insert(tx.end(), d, d + n); }
  uint8_t serial_tx_free() override { return 255; }
  uint8_t eeprom_read(uint16_t a) override { return eeprom[a]; }
  void eeprom_write(uint16_t a, uint8_t v) override {
    if (write_limit >= 0 && writes >= write_limit) return;
    ++writes;
    eeprom[a] = v;
  }
  void request_reset() override {}
  uint16_t free_stack() override { return 300; }
  uint8_t reset_cause() override { return 1; }
};

// One output per input; the estimate is set by the test; saturation on demand.
struct FakeModel : dev::ModelPort {
  int16_t est = 0;
  bool saturate = false;
  uint8_t begin(uint16_t, uint16_t, uint8_t, int16_t*) override { return r::OK; }
  uint8_t chunk(uint16_t, const uint8_t*, uint8_t, int16_t*) override { return r::OK; }
  uint8_t commit(int16_t*) override { return r::OK; }
  uint8_t erase() override { return r::OK; }
  uint8_t read(uint16_t, uint8_t, uint8_t*) override { return r::OK; }
  void info(proto::ModelInfoReply* o) override {
    memset(o, 0, sizeof *o);
    o->n_outputs = 3;
  }
  uint8_t status() override { return 1; }
  uint16_t crc() override { return 0xBEEF; }
  bool flash_store() override { return false; }
  bool estimator_loaded() override { return true; }
  void estimator_reset() override {}
  uint8_t estimator_step(const int16_t*, int16_t out[3]) override {
    out[0] = out[1] = out[2] = est;
    return saturate ? 1 : 0;
  }
};

struct Rig {
  FakeHal hal;
  FakeModel model;
  dev::Device dev{hal, model};
  uint8_t seq = 1;
  uint16_t session = 0, counter = 0;
  proto::FrameDecoder dec;
  size_t seen = 0;
  // The last ACK/NAK/reply type and NAK code.
  uint8_t last_type = 0, last_code = 0;

  void send(uint8_t type, const uint8_t* p, uint8_t n) {
    uint8_t buf[proto::kMaxFrameLen];
    const uint8_t len = proto::encode_frame(type, seq++, p, n, buf);
    hal.rx.insert(hal.rx.end(), buf, buf + len);
    dev.poll();
    for (; seen < hal.tx.size(); ++seen) {
      if (!dec.feed(hal.tx[seen])) continue;
      if (dec.type() == proto::msg::HELLO_REPLY) {
        proto::HelloReply h;
        h.decode(dec.payload(), dec.length());
        session = h.session;
      }
      if (dec.type() & 0x80 && dec.type() != proto::msg::SAMPLE && dec.type() != proto::msg::CONTROL_SAMPLE &&
          dec.type() != proto::msg::ERROR) {
        last_type = dec.type();
        last_code = dec.type() == proto::msg::NAK ? dec.payload()[1] : 0;
      }
    }
  }
  void start(uint16_t rate, const ctl::Gains& g, int16_t target, uint8_t mask = 1) {
    dev.begin();
    send(proto::msg::HELLO, nullptr, 0);
    uint8_t ss[3] = {(uint8_t)rate, (uint8_t)(rate >> 8), 0x1F};
    send(proto::msg::START_STREAM, ss, 3);
    uint8_t gb[ctl::kGainsBytes + 1];
    memcpy(gb, &g, ctl::kGainsBytes);
    gb[ctl::kGainsBytes] = 0;
    send(proto::msg::CONTROL_GAINS, gb, sizeof gb);
    uint8_t cs[12] = {0, mask};
    for (int i = 0; i < 3; ++i) proto::put_i16(cs + 2 + 2 * i, target);
    proto::put_u16(cs + 8, session);
    proto::put_u16(cs + 10, ++counter);
    send(proto::msg::CONTROL_START, cs, 12);
  }
  void sample() {
    hal.now_us += 10000;
    dev.on_sample_ticks(1, hal.now_us);
  }
};

struct E3 {
  int16_t v[3];
  E3(int a, int b, int c) { v[0] = (int16_t)a, v[1] = (int16_t)b, v[2] = (int16_t)c; }
};

ctl::Gains gains(uint16_t kp, uint16_t ki, uint16_t slew, uint16_t rate = 100) {
  ctl::Gains g;
  for (int i = 0; i < 3; ++i) g.kp_q16[i] = kp, g.ki_q22[i] = ki, g.slew_q4[i] = slew;
  g.model_crc = 0xBEEF;
  g.rate_hz = rate;
  return g;
}

// First-order plant: estimate (LSB) follows G * vacuum (dkPa) with pole a per sample.
struct Plant {
  double y, G, a;
  int16_t step(int16_t cmd) {
    y += a * (G * -cmd - y);
    return (int16_t)(y + 0.5);
  }
};

void test_pi_reaches_targets_on_random_plants() {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> gain(8.0, 60.0), pole(0.02, 0.2);
  double worst_err = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Plant p{0.0, gain(rng), pole(rng)};
    // A stated rule: the proportional part alone answers 1/(2 G) dkPa per LSB, the integral
    // closes the loop with time constant 1/a samples (IMC of a first-order plant).
    const double kp = 0.5 / p.G, ki = kp * p.a;
    const ctl::Gains g = gains((uint16_t)(kp * 65536), (uint16_t)(ki * 4194304.0), 65535);
    ctl::Controller c;
    const int16_t target = (int16_t)(0.6 * p.G * 600);  // reachable: 60 % of the stroke at -60 kPa
    c.set_target(0, target);
    c.start(1);
    int16_t est = 0, cmd[3] = {0, 0, 0};
    for (int k = 0; k < 600; ++k) {
      c.step(g, E3(est, 0, 0).v, -600, cmd);
      CHECK(cmd[0] <= 0 && cmd[0] >= -600);
      est = p.step(cmd[0]);
    }
    // The command moves in steps of 0.1 kPa (1 dkPa), which moves the estimate by G LSB: the
    // loop settles within one command step of the target (a limit cycle at most that wide).
    const double err = (est > target ? est - target : target - est) / p.G;
    if (err > worst_err) worst_err = err;
  }
  CHECK_MSG(worst_err <= 1.0, "worst steady-state error %.2f command steps", worst_err);
  printf(
      "PI on 200 random first-order plants: worst steady-state error %.2f command steps (x G LSB) "
      "after 600 samples\n",
      worst_err);
}

void test_anti_windup_and_limits() {
  Plant p{0.0, 10.0, 0.1};
  const ctl::Gains g = gains(3276, 20000, 65535);  // 0.05 dkPa/LSB, 0.0048 dkPa/LSB/sample
  ctl::Controller c;
  c.set_target(0, 20000);  // beyond the stroke: 10 LSB/dkPa * 300 dkPa = 3000 LSB at most
  c.start(1);
  int16_t est = 0, cmd[3] = {0, 0, 0};
  uint8_t pinned = 0;
  for (int k = 0; k < 2000; ++k) {
    pinned = c.step(g, E3(est, 0, 0).v, -300, cmd);
    CHECK(cmd[0] >= -300 && cmd[0] <= 0);
    est = p.step(cmd[0]);
  }
  CHECK(pinned == 1 && cmd[0] == -300);
  // A reachable target now: without wind-up the command leaves the limit as soon as the
  // slewed target (4096 LSB per sample at slew_q4 65535) passes below the estimate.
  const int bound = (20000 - est) / 4096 + 2;
  c.set_target(0, 1000);
  int left = -1;
  for (int k = 0; k < 50 && left < 0; ++k) {  // a wound-up integrator would hold it far longer
    c.step(g, E3(est, 0, 0).v, -300, cmd);
    if (cmd[0] > -300) left = k;
    est = p.step(cmd[0]);
  }
  CHECK_MSG(left >= 0 && left <= bound, "left the limit after %d samples (bound %d)", left, bound);
  // Random gains, targets and estimates: the command never leaves [min, 0].
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> u16(0, 65535), i16(-32768, 32767), tgt(-30000, 30000), lim(-800, 0);
  for (int k = 0; k < 20000; ++k) {
    ctl::Gains r = gains((uint16_t)(u16(rng) & 0x7FFF), (uint16_t)u16(rng), (uint16_t)(u16(rng) | 1));
    if (k % 100 == 0) c.start(7);
    c.set_target((uint8_t)(k % 3), (int16_t)tgt(rng));
    const int16_t e[3] = {(int16_t)i16(rng), (int16_t)i16(rng), (int16_t)i16(rng)};
    const int16_t m = (int16_t)lim(rng);
    c.step(r, e, m, cmd);
    for (int i = 0; i < 3; ++i) CHECK(cmd[i] <= 0 && cmd[i] >= m);
  }
}

void test_slew_limit() {
  const ctl::Gains g = gains(0, 0, 160);  // 10 LSB per sample
  ctl::Controller c;
  c.set_target(0, 1000);
  c.start(1);
  int16_t cmd[3];
  c.step(g, E3(-5, 0, 0).v, -600, cmd);  // starts at the estimate, then moves
  CHECK(c.slewed(0) == 5);
  for (int k = 2; k <= 101; ++k) {
    c.step(g, E3(0, 0, 0).v, -600, cmd);
    CHECK(c.slewed(0) == (k * 10 - 5 > 1000 ? 1000 : k * 10 - 5));
  }
  CHECK(c.slewed(1) == ctl::kNoTarget);
}

void test_device_vents_on_faults() {
  {  // sensor fault
    Rig rig;
    rig.start(100, gains(3276, 0, 65535), 5000);
    rig.sample();
    CHECK(rig.dev.flags() & f::CONTROL_ACTIVE);
    CHECK(rig.hal.out.valve_mask == 1 && rig.hal.out.setpoint_dkpa[0] < 0 && rig.hal.out.pump_mask == 1);
    rig.hal.adc_ok = false;
    rig.sample();
    CHECK(!(rig.dev.flags() & f::CONTROL_ACTIVE) && (rig.dev.flags() & f::CONTROL_ABORTED));
    CHECK(rig.hal.out.valve_mask == 0 && rig.hal.out.pump_mask == 0 && rig.hal.out.setpoint_dkpa[0] == 0);
  }
  {  // estimator saturated
    Rig rig;
    rig.start(100, gains(3276, 0, 65535), 5000);
    rig.sample();
    rig.model.saturate = true;
    rig.sample();
    CHECK(!(rig.dev.flags() & f::CONTROL_ACTIVE) && (rig.dev.flags() & f::CONTROL_ABORTED));
    CHECK(rig.hal.out.valve_mask == 0 && rig.hal.out.setpoint_dkpa[0] == 0);
  }
  {  // host lost: WATCHDOG_MS (1000) after the last command
    Rig rig;
    rig.start(100, gains(3276, 0, 65535), 5000);
    for (int k = 0; k < 100; ++k) rig.sample(), rig.dev.poll();
    CHECK(rig.dev.flags() & f::CONTROL_ACTIVE);
    rig.sample();
    rig.hal.now_us += 1000;
    rig.dev.poll();
    CHECK((rig.dev.flags() & f::WATCHDOG_TRIPPED) && (rig.dev.flags() & f::CONTROL_ABORTED));
    CHECK(rig.hal.out.valve_mask == 0 && rig.hal.out.setpoint_dkpa[0] == 0);
  }
  {  // refusals: gains for another rate, a target beyond the range, no stream
    Rig rig;
    rig.start(50, gains(3276, 0, 65535, 100), 5000);
    CHECK(rig.last_type == proto::msg::NAK && rig.last_code == r::BAD_STATE);
    Rig rig2;
    rig2.start(100, gains(3276, 0, 65535), 30001);
    CHECK(rig2.last_type == proto::msg::NAK && rig2.last_code == r::OUT_OF_RANGE);
    CHECK(!(rig2.dev.flags() & f::CONTROL_ACTIVE));
  }
}

std::vector<uint8_t> record(uint8_t n, int16_t y_step, uint16_t dt = 100) {
  std::vector<uint8_t> rec = {n, 1};
  for (uint8_t i = 0; i < n; ++i) {
    rec.push_back((uint8_t)(i * dt)), rec.push_back((uint8_t)((i * dt) >> 8));
    const int16_t y = (int16_t)(i * y_step);
    rec.push_back((uint8_t)y), rec.push_back((uint8_t)(y >> 8));
  }
  const uint16_t crc = proto::crc16(rec.data(), (uint16_t)rec.size());
  rec.push_back((uint8_t)crc), rec.push_back((uint8_t)(crc >> 8));
  return rec;
}

uint8_t write_all(dev::ControlStore& s, const std::vector<uint8_t>& rec, int16_t* detail) {
  uint8_t code = r::OK;
  for (size_t off = 0; off < rec.size() && code == r::OK; off += 20) {
    const uint8_t n = (uint8_t)(rec.size() - off < 20 ? rec.size() - off : 20);
    code = s.write(dev::ControlStore::kTraj, (uint8_t)rec.size(), (uint8_t)off, rec.data() + off, n, detail);
  }
  return code;
}

void test_trajectory_store_crc_and_torn_writes() {
  FakeHal hal;
  dev::ControlStore s(hal);
  s.boot();
  int16_t detail = -1;
  const std::vector<uint8_t> a = record(5, 100), b = record(6, -50);
  CHECK(write_all(s, a, &detail) == r::OK && s.has(dev::ControlStore::kTraj));
  std::vector<uint8_t> bad = a;
  bad[3] ^= 1;  // a time byte: the CRC fails
  CHECK(write_all(s, bad, &detail) == r::BAD_MODEL && detail == 0);
  std::vector<uint8_t> back = record(3, 10);
  back[2 + 4] = 0, back[2 + 5] = 0;  // point 1 at t = 0: not increasing
  const uint16_t crc = proto::crc16(back.data(), (uint16_t)(back.size() - 2));
  back[back.size() - 2] = (uint8_t)crc, back[back.size() - 1] = (uint8_t)(crc >> 8);
  CHECK(write_all(s, back, &detail) == r::BAD_MODEL && detail == 1);
  dev::ControlStore fresh(hal);
  fresh.boot();
  CHECK(fresh.has(dev::ControlStore::kTraj) && fresh.duration() == 400);  // still a
  // A power cut at every EEPROM write of writing b: after boot, a or b whole, never a mix.
  uint8_t image[1024];
  memcpy(image, hal.eeprom, sizeof image);
  int olds = 0, news = 0;
  for (long cut = 0; cut <= (long)b.size() + 4; ++cut) {
    FakeHal h;
    memcpy(h.eeprom, image, sizeof image);
    dev::ControlStore w(h);
    w.boot();
    h.write_limit = cut;
    write_all(w, b, &detail);
    dev::ControlStore after(h);
    after.boot();
    CHECK(after.has(dev::ControlStore::kTraj));
    const uint16_t d = after.duration();
    CHECK(d == 400 || d == 500);
    (d == 400 ? olds : news)++;
  }
  CHECK(olds > 0 && news > 0);
  // Interpolation: 1 column, y = 100 per 100 ticks.
  uint8_t seg = 0;
  int16_t y[3];
  fresh.targets(150, &seg, y);
  CHECK(y[0] == 150 && y[1] == 150 && seg == 1);
}

void test_gains_bytes_round_trip() {
  Rig rig;
  rig.dev.begin();
  const ctl::Gains g = gains(1234, 54321, 777, 80);
  uint8_t gb[ctl::kGainsBytes + 1];
  memcpy(gb, &g, ctl::kGainsBytes);
  gb[ctl::kGainsBytes] = 1;  // save
  rig.send(proto::msg::CONTROL_GAINS, gb, sizeof gb);
  CHECK(rig.last_type == proto::msg::ACK);
  rig.send(proto::msg::CONTROL_GAINS_GET, nullptr, 0);
  CHECK(rig.last_type == proto::msg::CONTROL_GAINS_REPLY);
  CHECK(memcmp(rig.dec.payload(), gb, ctl::kGainsBytes) == 0 && rig.dec.payload()[ctl::kGainsBytes] == 1);
  // Stored: a new boot reads the same bytes back.
  dev::ControlStore s(rig.hal);
  s.boot();
  CHECK(s.has(dev::ControlStore::kGains));
  CHECK(memcmp(rig.hal.eeprom + s.record(dev::ControlStore::kGains), gb, ctl::kGainsBytes) == 0);
  gb[0] = 0xFF, gb[1] = 0x7F + 1;  // kp 33023 > 32767
  rig.send(proto::msg::CONTROL_GAINS, gb, sizeof gb);
  CHECK(rig.last_type == proto::msg::NAK && rig.last_code == r::OUT_OF_RANGE);
}

int main() {
  test_pi_reaches_targets_on_random_plants();
  test_anti_windup_and_limits();
  test_slew_limit();
  test_device_vents_on_faults();
  test_trajectory_store_crc_and_torn_writes();
  test_gains_bytes_round_trip();
  printf("test_control: %d checks, %d failures\n", g_checks, g_failures);
  return g_failures ? 1 : 0;
}
