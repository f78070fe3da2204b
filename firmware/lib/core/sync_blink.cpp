#include "sync_blink.h"

namespace dev {

bool sync_blink_on(uint32_t elapsed_ms) {
  if (elapsed_ms < kSyncPeriodMs) {
    // Start code: on, gap, on; one unsigned compare per pulse.
    constexpr uint16_t second = kSyncStartOnMs + kSyncStartGapMs;
    return elapsed_ms < kSyncStartOnMs || (uint16_t)(elapsed_ms - second) < kSyncStartOn2Ms;
  }
  return elapsed_ms % kSyncPeriodMs < kSyncPulseMs;
}

bool SyncBlink::level(uint32_t tick_us) {
  if (!started_) {
    start_us_ = tick_us;
    started_ = true;
  }
  // Unsigned difference: correct across the 32-bit micros() wrap.
  return sync_blink_on((tick_us - start_us_) / 1000UL);
}

}  // namespace dev
