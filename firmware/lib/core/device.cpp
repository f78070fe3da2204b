#include "device.h"

#include <string.h>

#include "f32_bits.h"
#include "sensing.h"
#include "standalone_out.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

namespace {

// Out of line: inlined at its dozen call sites it costs 36 B more flash.
__attribute__((noinline)) uint16_t sat_add16(uint16_t a, uint16_t b) {
  return (uint16_t)(a > 0xFFFF - b ? 0xFFFF : a + b);
}
uint32_t sat_inc32(uint32_t a) { return a == 0xFFFFFFFFUL ? a : a + 1; }

// Field indices named by NAK.detail for OUT_OF_RANGE (position in the catalogue's field list).
constexpr int16_t kFieldSetpoint = 0, kFieldPumpMask = 1, kFieldValveMask = 2, kFieldSession = 3;

}  // namespace

Device::Device(Hal& hal, ModelPort& model) : DeviceState(), hal_(hal), model_(model), store_(hal), cstore_(hal) {
  config_.set_defaults();
}

void Device::begin() {
  outputs_off();
  if (store_.load(&config_)) {
    // Count boots in the stored configuration (only bytes that change are written).
    config_.boots = sat_add16(config_.boots, 1);
    store_.save(config_);
  } else {
    sticky_flags_ |= f::CONFIG_DEFAULTS;
  }
  apply_config();
  session_ = config_.boots;  // each boot starts another sequence of sessions (mixed at HELLO)
  if (!hal_.adc_present()) sample_flags_ |= f::ADC_FAULT;
  if (!hal_.imu_present()) sample_flags_ |= f::IMU_FAULT;
  const bool r0_stored = config_.r0_mode == 1 && !(sticky_flags_ & f::CONFIG_DEFAULTS);
  if (!r0_stored) {
    sticky_flags_ |= f::R0_UNCALIBRATED;  // cleared when a channel gives a usable R0
    calibrate_r0(kR0BootSamples, 0x07);
  }
  cstore_.boot();
  if (cstore_.has(ControlStore::kGains))
    for (uint8_t i = 0; i < ctl::kGainsBytes; ++i)
      ((uint8_t*)&gains_)[i] = hal_.eeprom_read((uint16_t)(cstore_.record(ControlStore::kGains) + i));
  if (config_.autostart && model_.estimator_loaded()) {
    start_stream(config_.sample_rate_hz,
                 (uint8_t)(config_.channel_mask | (config_.autostart == 2 ? proto::chan::ESTIMATES : 0)));
    sticky_flags_ |= f::STANDALONE;
    if (config_.autostart == 2) {
      // The stored trajectory with the stored gains: a 1-column one drives channel 0, a
      // 3-column one channels 0..2. Anything missing or unusable: flagged, outputs stay off.
      const uint8_t mask = cstore_.columns() == 3 ? 0x07 : 0x01;
      if (cstore_.has(ControlStore::kTraj) && cstore_.has(ControlStore::kGains) && gains_fit(gains_) &&
          control_mask_ok(mask))
        control_begin(kCtlTrajectory | kCtlStandalone, mask);
      else
        sticky_flags_ |= f::CONTROL_ABORTED;
    }
  }
  set_line_mode(config_.line_mode);
  link_.feed(hal_.millis());
}

void Device::apply_config() {
  link_.set_timeout(config_.watchdog_ms);
  hal_.adc_configure(config_.adc_pga, config_.adc_rate);
  // A pin stored by an older build that this one cannot drive counts as off.
  const uint8_t pin = config_.pwm_pin == kAnalogOutPin ? kAnalogOutPin : 0;
  if (pin != analog_pin_) {
    if (analog_pin_) hal_.analog_out(analog_pin_, 0);
    analog_pin_ = pin;
    if (pin) hal_.analog_out(pin, 0);
  }
}

uint16_t Device::flags() const {
  uint16_t fl = (uint16_t)(sticky_flags_ | sample_flags_);
  if (!model_.estimator_loaded()) fl |= f::ESTIMATOR_OFF;
  if (outputs_active()) fl |= f::OUTPUTS_ACTIVE;
  if (control_.active()) fl |= f::CONTROL_ACTIVE;
  if (pending_overrun_) fl |= f::OVERRUN;
  return fl;
}

// ---------------------------------------------------------------- outputs and watchdog

bool Device::outputs_active() const {
  if (outputs_.pump_mask || outputs_.valve_mask) return true;
  for (uint8_t i = 0; i < kChannels; ++i)
    if (outputs_.setpoint_dkpa[i] != 0) return true;
  return false;
}

void Device::outputs_off() {
  for (uint8_t i = 0; i < kChannels; ++i) outputs_.setpoint_dkpa[i] = 0;
  outputs_.pump_mask = 0;
  outputs_.valve_mask = 0;  // vented
  hal_.apply_outputs(outputs_);
}

void Device::poll() {
  poll_rx();
  if (frame_ready_) {
    handle_frame();
    frame_ready_ = false;
  }
  guard_link();
  // The trip's ERROR waits for room in the transmit buffer (telemetry may fill it) rather than
  // being dropped like a SAMPLE: header, 7-byte payload, CRC, COBS overhead and delimiter.
  if (trip_unreported_ && hal_.serial_tx_free() >= proto::kHeaderLen + proto::Error::kMaxLen + 2 + 2 + 1) {
    trip_unreported_ = 0;
    send_error(r::BAD_STATE, (int16_t)f::WATCHDOG_TRIPPED, trip_us_);
  }
}

void Device::guard_link() {
  // Standalone control (AUTOSTART 2, no host heard since boot) has no host to lose; everything
  // else needs a live link.
  const bool guarded = outputs_active() && !(control_mode_ & kCtlStandalone);
  if (!link_.expired(hal_.millis(), guarded)) return;
  if (control_.active()) sticky_flags_ |= f::CONTROL_ABORTED;
  control_stop();
  outputs_off();
  sticky_flags_ |= f::WATCHDOG_TRIPPED;
  counters_.watchdog_trips = sat_add16(counters_.watchdog_trips, 1);
  trip_unreported_ = 1;
  trip_us_ = hal_.micros();
}

void Device::poll_rx() {
  while (!frame_ready_) {
    const int16_t c = hal_.serial_read();
    if (c < 0) break;
    if (decoder_.feed((uint8_t)c)) {
      frame_ready_ = true;
      line_state_ = 0;  // a host speaks frames: this session answers in frames
      counters_.rx_frames = sat_inc32(counters_.rx_frames);
      // Only a host command keeps the outputs alive, never a device-to-host type: the board's
      // own frames echoed back (a TX-RX loopback, an echoing adapter). The decoder has
      // already dropped unknown types and wrong lengths. A host that speaks to a board
      // running standalone takes it over: from its first command the link watchdog guards the
      // outputs as in hosted mode, so a host that goes silent cannot leave the pumps running.
      if (!(decoder_.type() & 0x80)) {
        link_.feed(hal_.millis());
        control_mode_ = (uint8_t)(control_mode_ & ~kCtlStandalone);
      }
    }
  }
  guard_link();
}

// ---------------------------------------------------------------- replies

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

// ---------------------------------------------------------------- command dispatch

void Device::handle_frame() {
  const uint8_t type = decoder_.type();
  const uint8_t seq = decoder_.seq();
  uint8_t lo, hi;
  const bool command = !(type & 0x80) && proto::payload_bounds(type, &lo, &hi);
  // A retry carries the same sequence number and type: answer it without executing again.
  // HELLO is never a duplicate (a new host session must not collide with the last one).
  if (cached_len_ != 0 && type == last_type_ && seq == last_seq_ && type != proto::msg::HELLO) {
    hal_.serial_write(cached_, cached_len_);
    counters_.tx_frames = sat_inc32(counters_.tx_frames);
    return;
  }
  // A HELLO opens a new session (output commands of earlier ones are stale from now on),
  // unless it repeats the previous command's sequence number: the host's retry of a HELLO
  // whose reply was late must not leave it holding a session already replaced.
  if (type == proto::msg::HELLO && !(type == last_type_ && seq == last_seq_)) {
    session_ = (uint16_t)(session_ * 40503u + (uint16_t)hal_.micros() + 1);
    out_counter_ = 0;
  }
  last_type_ = type;
  last_seq_ = seq;
  cmd_seq_ = seq;
  const uint8_t len = decoder_.length();
  if (!command) {
    nak(r::UNKNOWN_TYPE, 0);  // also a device-to-host type sent to the device
    return;
  }
  // HELLO is answered whatever its payload (and version): a host of any release can ask.
  if ((len < lo || len > hi) && type != proto::msg::HELLO) {
    nak(r::BAD_LENGTH, (int16_t)lo);
    return;
  }
  dispatch(type, decoder_.payload(), len);
}

void Device::dispatch(uint8_t type, const uint8_t* p, uint8_t len) {
  namespace m = proto::msg;
  switch (type) {
    case m::HELLO:
      cmd_hello();
      cached_len_ = 0;  // HELLO clears the duplicate cache
      return;
    case m::PING: {
      proto::Pong pong;
      pong.nonce = proto::get_u32(p);
      pong.device_time_us = hal_.micros();
      uint8_t buf[proto::Pong::kMaxLen];
      reply(proto::Pong::kType, buf, pong.encode(buf));
      return;
    }
    case m::SET_OUTPUTS:
      cmd_set_outputs(p);
      return;
    case m::SET_WATCHDOG: {
      const uint16_t ms = proto::get_u16(p);
      if (config_.set(proto::config::WATCHDOG_MS, ms) != r::OK) return nak(r::OUT_OF_RANGE, 0);
      link_.set_timeout(ms);
      return ack();
    }
    case m::START_STREAM:
      cmd_start_stream(p);
      return;
    case m::STOP_STREAM:
      control_stop();  // control needs the stream
      stop_stream();
      sticky_flags_ &= (uint16_t)~f::STANDALONE;
      return ack();
    case m::REPLAY:
      cmd_replay(p, len);
      return;
    case m::CALIBRATE_R0:
      cmd_calibrate_r0(p);
      return;
    case m::SET_R0:
      cmd_set_r0(p);
      return;
    case m::STATUS:
      cmd_status();
      return;
    case m::CONFIG_GET: {
      proto::ConfigValue v;
      v.key = p[0];
      if (!config_.get(v.key, &v.value)) return nak(r::BAD_KEY, 0);
      uint8_t buf[proto::ConfigValue::kMaxLen];
      reply(proto::ConfigValue::kType, buf, v.encode(buf));
      return;
    }
    case m::CONFIG_SET:
      cmd_config_set(p);
      return;
    case m::CONFIG_SAVE:
      // EEPROM writes would stall sampling and the link watchdog
      if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
      store_.save(config_);
      sticky_flags_ &= (uint16_t)~f::CONFIG_DEFAULTS;
      return ack();
    case m::CONFIG_RESET: {
      if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
      const uint16_t boots = config_.boots;
      config_.set_defaults();
      config_.boots = boots;
      store_.save(config_);
      apply_config();
      sticky_flags_ &= (uint16_t)~f::CONFIG_DEFAULTS;
      return ack();
    }
    case m::RESET:
      outputs_off();
      ack();
      reset_requested_ = true;
      hal_.request_reset();
      return;
    case m::MODEL_BEGIN:
    case m::MODEL_CHUNK:
    case m::MODEL_COMMIT:
    case m::MODEL_INFO:
    case m::MODEL_ERASE:
    case m::MODEL_READ:
      cmd_model(type, p, len);
      return;
    case m::CONTROL_GAINS:
      cmd_control_gains(p);
      return;
    case m::CONTROL_GAINS_GET:
      cmd_control_gains_get();
      return;
    case m::CONTROL_START:
      cmd_control_start(p);
      return;
    case m::CONTROL_STOP:
      control_stop();
      return ack();
    case m::TRAJECTORY_CHUNK: {
      // EEPROM writes would hold the outputs past the link watchdog.
      if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
      int16_t detail = 0;
      const uint8_t code = cstore_.write(ControlStore::kTraj, p[0], p[1], p + 2, (uint8_t)(len - 2), &detail);
      return code == r::OK ? ack() : nak(code, detail);
    }
    default:
      nak(r::UNKNOWN_TYPE, 0);
      return;
  }
}

void Device::cmd_hello() {
  proto::HelloReply h;
  h.proto_major = proto::kVersionMajor;
  h.proto_minor = proto::kVersionMinor;
  h.fw_major = kFwMajor;
  h.fw_minor = kFwMinor;
  h.fw_patch = kFwPatch;
  h.capabilities = proto::cap::ESTIMATOR | proto::cap::PWM_OUT | proto::cap::LINE_MODE;
  if (hal_.adc_present()) h.capabilities |= proto::cap::ADC;
  if (hal_.imu_present()) h.capabilities |= proto::cap::IMU;
  if (model_.flash_store()) h.capabilities |= proto::cap::FLASH_STORE;
  h.n_channels = kChannels;
  h.model_status = model_.status();
  h.model_crc = model_.crc();
  h.streaming = streaming_ ? 1 : 0;
  h.uptime_ms = hal_.millis();
  h.session = session_;
  uint8_t buf[proto::HelloReply::kMaxLen];
  reply(proto::HelloReply::kType, buf, h.encode(buf));
}

void Device::cmd_set_outputs(const uint8_t* p) {
  proto::SetOutputs s;
  s.decode(p, proto::SetOutputs::kMinLen);
  for (uint8_t i = 0; i < kChannels; ++i) {
    if (s.setpoint_dkpa[i] > 0 || s.setpoint_dkpa[i] < config_.min_setpoint_dkpa)
      return nak(r::OUT_OF_RANGE, kFieldSetpoint);
  }
  if (s.pump_mask & ~0x07) return nak(r::OUT_OF_RANGE, kFieldPumpMask);
  if (s.valve_mask & ~0x07) return nak(r::OUT_OF_RANGE, kFieldValveMask);
  // All off is safe whatever its age; anything else must be fresh in this session.
  const bool any_on = s.pump_mask | s.valve_mask | s.setpoint_dkpa[0] | s.setpoint_dkpa[1] | s.setpoint_dkpa[2];
  if (any_on && !fresh(s.session, s.counter)) return nak(r::BAD_STATE, kFieldSession);
  control_stop();  // the host drives the outputs itself from now on
  for (uint8_t i = 0; i < kChannels; ++i) outputs_.setpoint_dkpa[i] = s.setpoint_dkpa[i];
  outputs_.pump_mask = s.pump_mask;
  outputs_.valve_mask = s.valve_mask;
  hal_.apply_outputs(outputs_);
  sticky_flags_ &= (uint16_t)~f::WATCHDOG_TRIPPED;
  link_.feed(hal_.millis());
  ack();
}

// Out of line: -18 B flash.
__attribute__((noinline)) bool Device::fresh(uint16_t session, uint16_t counter) {
  if (session != session_ || (uint16_t)(counter - out_counter_ - 1) >= 0x7FFF) return false;
  out_counter_ = counter;
  return true;
}

void Device::cmd_start_stream(const uint8_t* p) {
  proto::StartStream s;
  s.decode(p, proto::StartStream::kMinLen);
  proto::config::KeyInfo rate;
  proto::config::key_info(proto::config::SAMPLE_RATE_HZ, &rate);
#ifdef POROSENSE_RATE_LIMIT_HZ
  rate.max = POROSENSE_RATE_LIMIT_HZ;  // bench builds only: to find the real limit above it
#endif
  if (s.rate_hz < rate.min || s.rate_hz > rate.max) return nak(r::OUT_OF_RANGE, 0);
  if (s.channel_mask & ~0x1F) return nak(r::OUT_OF_RANGE, 1);
  sticky_flags_ &= (uint16_t)~f::STANDALONE;
  control_stop();  // a restarted estimator would give the controller a jump
  start_stream(s.rate_hz, s.channel_mask);
  ack();
}

// Out of line: -22 B flash.
__attribute__((noinline)) void Device::start_stream(uint16_t rate_hz, uint8_t mask) {
  model_.estimator_reset();
  stream_mask_ = mask;
  rate_hz_ = rate_hz;
  telemetry_seq_ = 0;  // each stream numbers its SAMPLE frames from 0
  pending_overrun_ = 0;
  streaming_ = true;
  sync_.restart();
}

void Device::stop_stream() {
  streaming_ = false;
  hal_.analog_out(kSyncPin, 0);
  rate_hz_ = 0;
}

void Device::cmd_replay(const uint8_t* p, uint8_t len) {
  if (streaming_) return nak(r::BUSY, 0);
  if (!model_.estimator_loaded()) return nak(r::NO_MODEL, 0);
  // Inputs must be whole int16 values and whole samples of three.
  const uint8_t values = (uint8_t)((len - 1) / 2);
  if ((len - 1) % 2 != 0 || values % kChannels != 0) return nak(r::BAD_LENGTH, 0);
  if (p[0]) model_.estimator_reset();
  // Replies mirror the request: same length, estimates interleaved like the inputs.
  uint8_t out[proto::ReplayResult::kMaxLen];
  uint8_t flags = 0;
  for (uint8_t s = 0; s < values; s = (uint8_t)(s + kChannels)) {
    int16_t in[kChannels], est[kChannels];
    for (uint8_t i = 0; i < kChannels; ++i) in[i] = proto::get_i16(p + 1 + 2 * (s + i));
    flags |= model_.estimator_step(in, est);
    for (uint8_t i = 0; i < kChannels; ++i) proto::put_i16(out + 1 + 2 * (s + i), est[i]);
  }
  out[0] = flags & 1;
  reply(proto::ReplayResult::kType, out, (uint8_t)(1 + 2 * values));
}

bool Device::calibrate_r0(uint8_t n_samples, uint8_t mask) {
  int32_t sum[kChannels] = {0, 0, 0};
  for (uint8_t k = 0; k < n_samples; ++k) {
    for (uint8_t ch = 0; ch < kChannels; ++ch) {
      if (!(mask & (1u << ch))) continue;
      int16_t c;
      if (!hal_.adc_start(ch) || !hal_.adc_finish(&c)) {
        counters_.sensor_faults = sat_add16(counters_.sensor_faults, 1);
        return false;
      }
      sum[ch] += c;
    }
  }
  bool any = false;
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    if (!(mask & (1u << ch))) continue;
    const int32_t mohm = counts_to_mohm(sum[ch], n_samples, config_.adc_pga);
    proto::config::KeyInfo lim;
    proto::config::key_info((uint8_t)(proto::config::R0_CH0_MOHM + ch), &lim);
    // An open (unwired) or shorted input gives no usable R0: keep the previous one.
    if (mohm < lim.min || mohm > lim.max) continue;
    config_.r0_mohm[ch] = mohm;
    any = true;
  }
  if (any) sticky_flags_ &= (uint16_t)~f::R0_UNCALIBRATED;
  return true;
}

void Device::cmd_calibrate_r0(const uint8_t* p) {
  const uint8_t n = p[0], mask = p[1];
  if (n < 1 || n > 64) return nak(r::OUT_OF_RANGE, 0);
  if (mask == 0 || (mask & ~0x07)) return nak(r::OUT_OF_RANGE, 1);
  // Calibration blocks (up to 24 s at 8 SPS): never while an output needs the link watchdog.
  if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
  if (!calibrate_r0(n, mask)) return nak(r::SENSOR_FAULT, 0);
  proto::R0Reply rep;
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    const uint32_t bits = f32_from_ratio((uint32_t)config_.r0_mohm[ch], 1000);  // R0 >= 1000 mohm
    memcpy(&rep.r0_ohm[ch], &bits, 4);
  }
  uint8_t buf[proto::R0Reply::kMaxLen];
  reply(proto::R0Reply::kType, buf, rep.encode(buf));
}

void Device::cmd_set_r0(const uint8_t* p) {
  proto::SetR0 s;
  s.decode(p, proto::SetR0::kMinLen);
  if (s.channel_mask == 0 || (s.channel_mask & ~0x07)) return nak(r::OUT_OF_RANGE, 0);
  int32_t mohm[kChannels];
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    if (!(s.channel_mask & (1u << ch))) continue;
    uint32_t bits;
    memcpy(&bits, &s.r0_ohm[ch], 4);
    proto::config::KeyInfo lim;
    proto::config::key_info((uint8_t)(proto::config::R0_CH0_MOHM + ch), &lim);
    // R0 rounded to the milliohm; NaN and infinities fail too.
    if (!f32_scaled(bits, 1000, lim.max + 1, &mohm[ch]) || mohm[ch] < lim.min || mohm[ch] > lim.max)
      return nak(r::OUT_OF_RANGE, 1);
  }
  for (uint8_t ch = 0; ch < kChannels; ++ch)
    if (s.channel_mask & (1u << ch)) config_.r0_mohm[ch] = mohm[ch];
  sticky_flags_ &= (uint16_t)~f::R0_UNCALIBRATED;
  ack();
}

void Device::cmd_status() {
  const proto::DecoderCounters& d = decoder_.counters();
  proto::StatusReply s;
  s.flags = flags();
  s.bad_crc = sat_add16(d.bad_crc, d.bad_cobs);  // both are corrupted frames
  s.bad_length = sat_add16(d.bad_length, d.overlong);
  s.bad_version = d.bad_version;
  s.unknown_type = d.unknown_type;
  s.overruns = counters_.overruns;
  s.dropped_telemetry = counters_.dropped_telemetry;
  s.resets = config_.boots;
  s.reset_cause = hal_.reset_cause();
  s.watchdog_trips = counters_.watchdog_trips;
  s.sensor_faults = counters_.sensor_faults;
  s.free_ram = hal_.free_stack();
  s.rx_frames = counters_.rx_frames;
  s.tx_frames = counters_.tx_frames;
  s.uptime_ms = hal_.millis();
  uint8_t buf[proto::StatusReply::kMaxLen];
  reply(proto::StatusReply::kType, buf, s.encode(buf));
}

void Device::cmd_config_set(const uint8_t* p) {
  namespace k = proto::config;
  const uint8_t key = p[0];
  const int32_t value = proto::get_i32(p + 1);
  // Within the catalogue's limits but outside this build: stored schedules (no EEPROM room
  // for them) and PWM pins whose timer the firmware uses.
  if ((key == k::SCHEDULE_ENABLE && value != 0) ||
      (key == k::PWM_PIN && value >= 0 && value <= 255 && !analog_out_pin_ok((uint8_t)value)))
    return nak(r::UNSUPPORTED, 1);
  const uint8_t code = config_.set(key, value);
  if (code == r::BAD_KEY) return nak(code, 0);
  if (code != r::OK) return nak(code, 1);
  if (key == k::LINE_MODE) set_line_mode(value != 0);
  if (key >= proto::config::R0_CH0_MOHM && key <= proto::config::R0_CH2_MOHM)
    sticky_flags_ &= (uint16_t)~f::R0_UNCALIBRATED;
  apply_config();
  ack();
}

void Device::cmd_model(uint8_t type, const uint8_t* p, uint8_t len) {
  namespace m = proto::msg;
  int16_t detail = 0;
  uint8_t code = r::OK;
  switch (type) {
    case m::MODEL_INFO: {
      proto::ModelInfoReply info;
      model_.info(&info);
      uint8_t buf[proto::ModelInfoReply::kMaxLen];
      reply(proto::ModelInfoReply::kType, buf, info.encode(buf));
      return;
    }
    case m::MODEL_READ: {
      const uint16_t offset = proto::get_u16(p);
      const uint8_t n = p[2];
      if (n < 1 || n > 112) return nak(r::OUT_OF_RANGE, 1);
      uint8_t buf[2 + 112];
      proto::put_u16(buf, offset);
      code = model_.read(offset, n, buf + 2);
      if (code != r::OK) return nak(code, 0);
      reply(proto::ModelData::kType, buf, (uint8_t)(2 + n));
      return;
    }
    default:
      break;
  }
  // EEPROM writes (0.4 s per chunk) would hold the outputs past the link watchdog.
  if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
  switch (type) {
    case m::MODEL_BEGIN:
      code = model_.begin(proto::get_u16(p), proto::get_u16(p + 2), p[4], &detail);
      break;
    case m::MODEL_CHUNK:
      code = model_.chunk(proto::get_u16(p), p + 2, (uint8_t)(len - 2), &detail);
      break;
    case m::MODEL_COMMIT:
      code = model_.commit(&detail);
      break;
    case m::MODEL_ERASE:
      code = model_.erase();
      break;
    default:
      code = r::UNKNOWN_TYPE;
      break;
  }
  if (code != r::OK) return nak(code, detail);
  ack();
}

// ---------------------------------------------------------------- sampling

void Device::on_sample_ticks(uint8_t n, uint32_t tick_us) {
  if (n == 0 || !streaming_) return;
  hal_.analog_out(kSyncPin, sync_.level(tick_us) ? 255 : 0);  // camera sync, first: least lag
  if (n > 1) {
    counters_.overruns = sat_add16(counters_.overruns, (uint16_t)(n - 1));
    pending_overrun_ = 1;
    telemetry_seq_ = (uint8_t)(telemetry_seq_ + n - 1);  // the host counts the gap as lost samples
  }
  proto::Sample s;
  s.t_us = tick_us;
  s.channel_mask = stream_mask_;
  for (uint8_t i = 0; i < kChannels; ++i) {
    s.adc[i] = 0;
    s.dr_centi[i] = 0;
    s.euler_16[i] = 0;
    s.estimate[i] = 0;
  }
  const bool estimating = (stream_mask_ & proto::chan::ESTIMATES) && model_.estimator_loaded();
  // The estimator needs every input channel, even those not reported.
  const uint8_t adc_mask = (uint8_t)((stream_mask_ & 0x07) | (estimating ? 0x07 : 0));
  uint16_t fl = 0;
  int16_t dr[kChannels] = {0, 0, 0};
  // Channels in conversion order; each conversion runs while the previous channel's dR (and,
  // during the first one, the IMU read) is computed.
  uint8_t order[kChannels];
  uint8_t n_adc = 0;
  for (uint8_t ch = 0; ch < kChannels; ++ch)
    if (adc_mask & (1u << ch)) order[n_adc++] = ch;
  bool adc_ok = n_adc == 0 || hal_.adc_start(order[0]);
  if (stream_mask_ & proto::chan::IMU) {
    uint8_t cal = 0;
    if (!hal_.imu_read(s.euler_16, &cal)) {
      fl |= f::IMU_FAULT;
      for (uint8_t i = 0; i < kChannels; ++i) s.euler_16[i] = 0;
    } else if (cal < 3) {
      fl |= f::IMU_UNCALIBRATED;
    }
  }
  for (uint8_t k = 0; k < n_adc && adc_ok; ++k) {
    int16_t c = 0;
    if (!hal_.adc_finish(&c)) {
      adc_ok = false;  // the remaining channels would wait on the same missing chip
      break;
    }
    if (k + 1 < n_adc) adc_ok = hal_.adc_start(order[k + 1]);
    const uint8_t ch = order[k];
    if (adc_clipped(c)) fl |= f::ADC_CLIPPED;
    dr[ch] = counts_to_dr_centi(c, config_.adc_pga, config_.r0_mohm[ch]);
    if (stream_mask_ & (1u << ch)) {
      s.adc[ch] = c;
      s.dr_centi[ch] = dr[ch];
    }
  }
  if (!adc_ok) fl |= f::ADC_FAULT;
  poll_rx();
  if (estimating && !(fl & f::ADC_FAULT)) {
    if (model_.estimator_step(dr, s.estimate) & 1) fl |= f::ESTIMATOR_SATURATED;
    analog_out(s.estimate[0]);
  }
  bool aborted = false;
  const bool controlling = control_.active();
  if (controlling) fl = control_step(fl, estimating, s.estimate, tick_us, &aborted);
  // A sensor that stops answering is reported once, as it happens.
  const uint16_t faults = f::ADC_FAULT | f::IMU_FAULT;
  const uint16_t new_faults = (uint16_t)(fl & faults & ~(sample_flags_ & faults));
  if (fl & faults) counters_.sensor_faults = sat_add16(counters_.sensor_faults, 1);
  sample_flags_ = fl;
  s.status = flags();
  pending_overrun_ = 0;
  if (line_state_ & kLineOn) {
    send_line(s, estimating);
  } else {
    // While controlling, CONTROL_SAMPLE: SAMPLE's bytes, then targets and commands.
    uint8_t buf[proto::ControlSample::kMaxLen];
    uint8_t n = s.encode(buf);
    if (controlling) {
      for (uint8_t i = 0; i < kChannels; ++i) {
        proto::put_i16(buf + n + 2 * i, control_.slewed(i));
        proto::put_i16(buf + n + 6 + 2 * i, outputs_.setpoint_dkpa[i]);
      }
      n = (uint8_t)(n + 12);
    }
    send_unsolicited(controlling ? proto::ControlSample::kType : proto::Sample::kType, buf, n);
  }
  if (new_faults) send_error(r::SENSOR_FAULT, (int16_t)new_faults, tick_us);
  if (aborted) send_error(r::BAD_STATE, (int16_t)f::CONTROL_ABORTED, tick_us);
  poll_rx();
}

void Device::analog_out(int16_t estimate0) {
  if (analog_pin_)
    hal_.analog_out(analog_pin_, analog_out_duty(estimate0, config_.pwm_scale_milli, config_.pwm_offset));
}

uint8_t Device::line_estimates(proto::ModelInfoReply* info, uint8_t mask) {
  model_.info(info);
  return (mask & proto::chan::ESTIMATES) && model_.estimator_loaded() ? info->n_outputs : 0;
}

void Device::set_line_mode(bool on) {
  line_state_ = on ? kLineOn : 0;
  if (!on) return;
  char text[kHeaderMax];
  proto::ModelInfoReply info;
  const uint8_t mask = streaming_ ? stream_mask_ : config_.channel_mask;
  hal_.serial_write((const uint8_t*)text, format_header(text, (uint8_t)(mask & 0x07), line_estimates(&info, mask)));
}

// Kept out of line: its text buffer must not share a stack frame with a SAMPLE frame's.
__attribute__((noinline)) void Device::send_line(const proto::Sample& s, bool estimating) {
  char text[kLineMax];
  const uint8_t dr_mask = (uint8_t)(s.channel_mask & 0x07);
  proto::ModelInfoReply info;
  const uint8_t n_est = estimating ? line_estimates(&info, s.channel_mask) : 0;
  int32_t est_milli[kChannels];
  for (uint8_t j = 0; j < n_est; ++j) {
    // Output units with three decimals, exact (rounded half away from zero), saturated
    // at +-2e9.
    uint32_t scale;
    memcpy(&scale, &info.out_scale[j], 4);
    f32_scaled(scale, (int32_t)s.estimate[j] * 1000, 2000000000L, &est_milli[j]);
  }
  const uint8_t n = format_line(text, s.t_us / 1000UL, dr_mask, s.dr_centi, n_est, est_milli);
  // Like a SAMPLE frame, a line that does not fit the transmit buffer is dropped whole; one
  // longer than the whole buffer (63 bytes) goes out when the buffer is empty.
  const uint8_t room = hal_.serial_tx_free();
  if (room < n && room < kTxBufferFree) {
    counters_.dropped_telemetry = sat_add16(counters_.dropped_telemetry, 1);
    return;
  }
  hal_.serial_write((const uint8_t*)text, n);
}

// ---------------------------------------------------------------- strain control

void Device::cmd_control_gains(const uint8_t* p) {
  ctl::Gains g;
  memcpy(&g, p, ctl::kGainsBytes);  // wire layout = struct layout (control.h)
  const uint8_t save = p[ctl::kGainsBytes];
  for (uint8_t i = 0; i < kChannels; ++i) {
    if (g.kp_q16[i] > ctl::kMaxKp) return nak(r::OUT_OF_RANGE, 0);
    if (g.slew_q4[i] == 0) return nak(r::OUT_OF_RANGE, 2);
  }
  if (save > 1) return nak(r::OUT_OF_RANGE, 5);
  // EEPROM writes would stall sampling and the link watchdog.
  if (save && (streaming_ || outputs_active())) return nak(r::BUSY, 0);
  if (control_.active() && !gains_fit(g)) return nak(r::BAD_STATE, 2);
  gains_ = g;
  if (save) {
    uint8_t rec[ctl::kGainsBytes + 2];
    memcpy(rec, &g, ctl::kGainsBytes);
    proto::put_u16(rec + ctl::kGainsBytes, proto::crc16(rec, ctl::kGainsBytes));
    int16_t detail;
    cstore_.write(ControlStore::kGains, sizeof(rec), 0, rec, sizeof(rec), &detail);
  }
  ack();
}

void Device::cmd_control_gains_get() {
  uint8_t buf[ctl::kGainsBytes + 1];
  memcpy(buf, &gains_, ctl::kGainsBytes);
  buf[ctl::kGainsBytes] = cstore_.has(ControlStore::kGains) ? 1 : 0;
  reply(proto::ControlGainsReply::kType, buf, sizeof(buf));
}

void Device::cmd_control_start(const uint8_t* p) {
  const uint8_t mode = p[0], mask = p[1];
  if (!model_.estimator_loaded()) return nak(r::NO_MODEL, 0);
  if (!streaming_ || !(stream_mask_ & proto::chan::ESTIMATES)) return nak(r::BAD_STATE, 0);
  if (mode > 1) return nak(r::OUT_OF_RANGE, 0);
  if (!control_mask_ok(mask)) return nak(r::OUT_OF_RANGE, 1);
  int16_t target[kChannels];
  for (uint8_t i = 0; i < kChannels; ++i) {
    target[i] = proto::get_i16(p + 2 + 2 * i);
    if (mode == 0 && (mask >> i & 1) && (target[i] > ctl::kTargetLimit || target[i] < -ctl::kTargetLimit))
      return nak(r::OUT_OF_RANGE, 2);
  }
  if (mode == 1 && !cstore_.has(ControlStore::kTraj)) return nak(r::BAD_STATE, 1);
  if (!gains_fit(gains_)) return nak(r::BAD_STATE, 2);
  if (!fresh(proto::get_u16(p + 8), proto::get_u16(p + 10))) return nak(r::BAD_STATE, kFieldSession);
  control_stop();
  for (uint8_t i = 0; i < kChannels; ++i) control_.set_target(i, target[i]);
  control_begin(mode ? kCtlTrajectory : kCtlConstant, mask);
  link_.feed(hal_.millis());
  ack();
}

bool Device::gains_fit(const ctl::Gains& g) { return g.rate_hz == rate_hz_ && g.model_crc == model_.crc(); }

void Device::control_begin(uint8_t mode, uint8_t mask) {
  sticky_flags_ &= (uint16_t) ~(f::CONTROL_ABORTED | f::WATCHDOG_TRIPPED);
  control_mode_ = mode;
  traj_seg_ = 0;
  traj_start_us_ = hal_.micros();
  control_.start(mask);
  // The controller owns every output: the controlled chambers connect to the regulators,
  // the others vent. Commands start at 0 (ambient) until the first sample.
  for (uint8_t i = 0; i < kChannels; ++i) outputs_.setpoint_dkpa[i] = 0;
  outputs_.pump_mask = 0;
  outputs_.valve_mask = mask;
  hal_.apply_outputs(outputs_);
}

void Device::control_stop() {
  if (!control_.active()) return;
  control_.stop();
  control_mode_ = 0;
  outputs_off();
}

void Device::trajectory_targets(uint32_t tick_us) {
  const uint16_t t_end = cstore_.duration();
  uint32_t el = (tick_us - traj_start_us_) / 10000UL;  // 10 ms ticks
  if (el >= t_end && cstore_.repeat()) {               // next lap
    traj_start_us_ += (uint32_t)t_end * 10000UL;
    el -= t_end;
    traj_seg_ = 0;
  }
  int16_t y[kChannels];
  cstore_.targets((uint16_t)(el > t_end ? t_end : el), &traj_seg_, y);
  for (uint8_t i = 0; i < kChannels; ++i) control_.set_target(i, y[i]);
}

bool Device::control_mask_ok(uint8_t mask) {
  proto::ModelInfoReply info;
  model_.info(&info);
  return mask && !(mask >> info.n_outputs);
}

// Out of line: inlined into on_sample_ticks by link-time optimisation it costs ~320 B of flash.
__attribute__((noinline)) uint16_t Device::control_step(uint16_t fl, bool estimating, const int16_t est[kChannels],
                                                        uint32_t tick_us, bool* aborted) {
  // Never hold a command on an estimate that cannot be trusted: vent and stop.
  if (!estimating || (fl & (f::ADC_FAULT | f::ESTIMATOR_SATURATED))) {
    control_stop();
    sticky_flags_ |= f::CONTROL_ABORTED;
    *aborted = true;
    return (uint16_t)(fl | f::CONTROL_SATURATED);
  }
  if (control_mode_ & kCtlTrajectory) trajectory_targets(tick_us);
  const uint8_t sat = control_.step(gains_, est, config_.min_setpoint_dkpa, outputs_.setpoint_dkpa);
  uint8_t pumps = 0;
  for (uint8_t i = 0; i < kChannels; ++i)
    if (outputs_.setpoint_dkpa[i] < 0) pumps = (uint8_t)(pumps | (1u << i));  // vacuum asked: pump on
  outputs_.pump_mask = pumps;
  hal_.apply_outputs(outputs_);
  return sat ? (uint16_t)(fl | f::CONTROL_SATURATED) : fl;
}

}  // namespace dev
