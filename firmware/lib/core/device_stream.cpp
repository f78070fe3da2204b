// Fixed-rate sampling: starting and stopping the stream, one sample per tick (sensors, estimator,
// control, telemetry) and the analogue estimate output.
#include "device.h"

#include "device_util.h"
#include "sensing.h"
#include "standalone_out.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

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

}  // namespace dev
