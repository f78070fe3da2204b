// The strain controller: per channel a PI law on the on-device estimate with conditional
// integration (anti-windup) and a slew limit on the target; its output is the proportional
// regulator's vacuum setpoint. Pure integer logic (no hardware, no float).
//
// Units: targets and estimates in estimate LSB (value = raw * out_scale); commands in
// 0.1 kPa (dkPa) of gauge vacuum (<= 0). The gains are per LSB and per sample, made by the
// host for one model and one rate (porosense.device.control):
//   kp_q16  Q16 dkPa per LSB of error            (<= 32767)
//   ki_q22  Q22 dkPa per LSB per sample
//   slew_q4 Q4 LSB per sample                    (>= 1)
// With |error| clamped to 32767 every product of the step fits an int32.
#pragma once
#include <stdint.h>

namespace ctl {

constexpr uint8_t kChannels = 3;
constexpr int16_t kTargetLimit = 30000;  // the quantizer maps the design output range here
constexpr int16_t kNoTarget = -32768;    // CONTROL_SAMPLE.target of a channel not controlled
constexpr uint16_t kMaxKp = 32767;

// Laid out as CONTROL_GAINS / CONTROL_GAINS_REPLY carry it (little-endian, as the AVR and
// the host builds are), so the wire and EEPROM bytes copy straight in and out.
struct Gains {
  uint16_t kp_q16[kChannels];
  uint16_t ki_q22[kChannels];
  uint16_t slew_q4[kChannels];
  uint16_t model_crc;  // of the model they were made for
  uint16_t rate_hz;    // 0: never set (all gains zero)
};
constexpr uint8_t kGainsBytes = 22;

class Controller {
 public:
  Controller();
  // Starts the masked channels from rest (integrator 0); the slewed target starts at the
  // first estimate, so a step target ramps from where the actuator is.
  void start(uint8_t mask);
  void stop() { mask_ = 0; }
  uint8_t mask() const { return mask_; }
  bool active() const { return mask_ != 0; }
  void set_target(uint8_t ch, int16_t target) { ch_[ch].target = target; }
  // The slewed target now (LSB), kNoTarget for a channel not controlled.
  int16_t slewed(uint8_t ch) const;
  // One sample: estimates (LSB) -> vacuum commands (dkPa, min_dkpa..0) of the masked
  // channels (others untouched). Returns the mask of channels whose command is pinned with
  // error left (at min_dkpa wanting more vacuum, or at 0 wanting less).
  uint8_t step(const Gains& g, const int16_t estimate[kChannels], int16_t min_dkpa, int16_t command[kChannels]);

 private:
  uint8_t mask_;
  uint8_t fresh_;  // channels whose slewed target takes the next estimate
  struct Channel {
    int32_t slewed_q8;
    int32_t integ_q16;  // vacuum magnitude, Q16 dkPa, within [0, -min_dkpa]
    int16_t target;
  };
  Channel ch_[kChannels];
};

}  // namespace ctl
