// Supervision of the strain controller: gains, start and stop, the stored trajectory's targets, and
// the step that vents on an estimate that cannot be trusted.
#include "device.h"

#include <string.h>

#include "device_util.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

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
