// Command dispatch: duplicate detection, length checks, and the commands that need no subsystem of
// their own (handshake, outputs, status, configuration, the model store, replay).
#include "device.h"

#include <string.h>

#include "device_util.h"
#include "f32_bits.h"
#include "standalone_out.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

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

}  // namespace dev
