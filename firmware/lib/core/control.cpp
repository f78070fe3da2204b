#include "control.h"

namespace ctl {

namespace {

// Out of line: one copy of the 32-bit compares serves every clamp of the step.
__attribute__((noinline)) int32_t clamp(int32_t v, int32_t lo, int32_t hi) { return v < lo ? lo : v > hi ? hi : v; }

// 16 x 16 -> 32-bit product (one widening multiply on the AVR, not a 32 x 32 one).
inline int32_t mul(int16_t a, uint16_t b) { return (int32_t)a * (int32_t)b; }

}  // namespace

Controller::Controller() : mask_(0), fresh_(0) {
  for (uint8_t i = 0; i < kChannels; ++i) ch_[i] = Channel();
}

void Controller::start(uint8_t mask) {
  mask_ = fresh_ = mask;
  for (uint8_t i = 0; i < kChannels; ++i) ch_[i].integ_q16 = 0;
}

int16_t Controller::slewed(uint8_t ch) const {
  return (mask_ >> ch & 1) ? (int16_t)((ch_[ch].slewed_q8 + 128) >> 8) : kNoTarget;
}

uint8_t Controller::step(const Gains& g, const int16_t estimate[kChannels], int16_t min_dkpa,
                         int16_t command[kChannels]) {
  uint8_t pinned_mask = 0;
  const int32_t vac_max = -(int32_t)min_dkpa;  // MIN_SETPOINT_DKPA is -800..0
  for (uint8_t i = 0; i < kChannels; ++i) {
    if (!(mask_ >> i & 1)) continue;
    Channel& c = ch_[i];
    const int16_t est = estimate[i];
    if (fresh_ >> i & 1) c.slewed_q8 = est * 256L;
    // Slew: the target moves toward its goal by at most slew_q4 / 16 LSB per sample.
    const int32_t lim = (int32_t)g.slew_q4[i] * 16;
    c.slewed_q8 += clamp(c.target * 256L - c.slewed_q8, -lim, lim);
    // |error| clamped to 32767 with kp_q16 <= 32767 and ki_q22 <= 65535: every product and
    // sum below stays within int32.
    const int16_t e = (int16_t)clamp(((c.slewed_q8 + 128) >> 8) - est, -32767, 32767);
    // PI on the vacuum magnitude: more vacuum contracts more.
    const int32_t integ = c.integ_q16 + ((mul(e, g.ki_q22[i]) + 32) >> 6);  // Q22 -> Q16
    const int32_t u = (mul(e, g.kp_q16[i]) + integ + 32768) >> 16;
    // Conditional integration: hold the integrator while the output is pinned and the error
    // would push it further (no wind-up); keep it within the output range.
    if ((u >= vac_max && e > 0) || (u <= 0 && e < 0))
      pinned_mask |= (uint8_t)(1u << i);
    else
      c.integ_q16 = clamp(integ, 0, vac_max * 65536L);
    command[i] = (int16_t)-clamp(u, 0, vac_max);
  }
  fresh_ = 0;
  return pinned_mask;
}

}  // namespace ctl
