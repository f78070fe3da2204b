// The device's life: boot, configuration, flags, the outputs and the host-link watchdog that guards
// them, and the loop's receive path.
#include "device.h"

#include <string.h>

#include "device_util.h"
#include "sensing.h"
#include "standalone_out.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

// Out of line: inlined at its dozen call sites it costs 36 B more flash.
__attribute__((noinline)) uint16_t sat_add16(uint16_t a, uint16_t b) {
  return (uint16_t)(a > 0xFFFF - b ? 0xFFFF : a + b);
}

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

}  // namespace dev
