#include "control.h"

namespace ctl {

Controller::Controller() : mask_(0), fresh_(0) {
  for (uint8_t i = 0; i < kChannels; ++i) {
    slewed_q8_[i] = integ_q16_[i] = 0;
    target_[i] = 0;
  }
}

void Controller::start(uint8_t mask) {
  mask_ = fresh_ = mask;
  for (uint8_t i = 0; i < kChannels; ++i) integ_q16_[i] = 0;
}

int16_t Controller::slewed(uint8_t ch) const {
  return (mask_ >> ch & 1) ? (int16_t)((slewed_q8_[ch] + 128) >> 8) : kNoTarget;
}

uint8_t Controller::step(const Gains& g, const int16_t estimate[kChannels], int16_t min_dkpa,
                         int16_t command[kChannels]) {
  uint8_t pinned_mask = 0;
  const int32_t vac_max = -(int32_t)min_dkpa;  // MIN_SETPOINT_DKPA is -800..0
  for (uint8_t i = 0; i < kChannels; ++i) {
    const uint8_t bit = (uint8_t)(1u << i);
    if (!(mask_ & bit)) continue;
    if (fresh_ & bit) slewed_q8_[i] = (int32_t)estimate[i] << 8;
    fresh_ &= (uint8_t)~bit;
    // Slew: the target moves toward its goal by at most slew_q4 / 16 LSB per sample.
    const int32_t lim = (int32_t)g.slew_q4[i] << 4;
    int32_t d = ((int32_t)target_[i] << 8) - slewed_q8_[i];
    slewed_q8_[i] += d > lim ? lim : d < -lim ? -lim : d;
    int32_t e = ((slewed_q8_[i] + 128) >> 8) - estimate[i];
    if (e > 32767) e = 32767;
    if (e < -32767) e = -32767;
    // PI on the vacuum magnitude: more vacuum contracts more.
    int32_t integ = integ_q16_[i] + (((int32_t)g.ki_q24[i] * e + 128) >> 8);
    int32_t u = ((int32_t)g.kp_q16[i] * e + integ + 32768) >> 16;
    const bool pinned = (u >= vac_max && e > 0) || (u <= 0 && e < 0);
    if (u > vac_max) u = vac_max;
    if (u < 0) u = 0;
    // Conditional integration: hold the integrator while the output is pinned and the error
    // would push it further (no wind-up); keep it within the output range.
    if (pinned) {
      pinned_mask |= bit;
    } else {
      if (integ < 0) integ = 0;
      if (integ > (vac_max << 16)) integ = vac_max << 16;
      integ_q16_[i] = integ;
    }
    command[i] = (int16_t)-u;
  }
  return pinned_mask;
}

}  // namespace ctl
