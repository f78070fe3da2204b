// Turns a fixed 1 kHz timer tick into sample ticks at rate_hz (10 Hz .. the SAMPLE_RATE_HZ max) without drift:
// a Bresenham accumulator, so rates that do not divide 1000 alternate between the two
// nearest whole periods and keep the exact mean rate. Called from the timer interrupt (change the rate with interrupts
// off).
#pragma once
#include <stdint.h>

namespace dev {

constexpr uint16_t kTickHz = 1000;

class RateDivider {
 public:
  RateDivider() : rate_(0), acc_(0) {}
  void set_rate(uint16_t rate_hz) {
    rate_ = rate_hz;
    acc_ = 0;
  }  // 0 stops sampling
  uint16_t rate() const { return rate_; }
  bool tick() {
    if (rate_ == 0) return false;
    acc_ = (uint16_t)(acc_ + rate_);
    if (acc_ < kTickHz) return false;
    acc_ = (uint16_t)(acc_ - kTickHz);
    return true;
  }

 private:
  uint16_t rate_;
  uint16_t acc_;
};

}  // namespace dev
