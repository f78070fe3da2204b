// Host-link watchdog: while any output is active, a gap of more than timeout_ms without a
// valid frame means the host is gone and the outputs must be cut. Pure logic; times in ms.
#pragma once
#include <stdint.h>

namespace dev {

class LinkWatchdog {
 public:
  LinkWatchdog() : timeout_ms_(1000), last_ms_(0) {}
  void set_timeout(uint16_t ms) { timeout_ms_ = ms; }
  uint16_t timeout() const { return timeout_ms_; }
  void feed(uint32_t now_ms) { last_ms_ = now_ms; }  // a valid frame arrived
  // True when outputs are active and the link has been silent for longer than the timeout.
  bool expired(uint32_t now_ms, bool outputs_active) const {
    return outputs_active && (uint32_t)(now_ms - last_ms_) > timeout_ms_;
  }

 private:
  uint16_t timeout_ms_;
  uint32_t last_ms_;
};

}  // namespace dev
