// Sync indicator for camera recordings: from the first sample of a stream the board drives
// an indicator output (an LED) in a fixed pattern that a camera sees, so video frames can be
// placed on the board's clock (docs/camera.md, pin in docs/hardware.md).
//
// Pattern, in ms since the stream's first sample (boundaries fall on sample ticks):
//   start code   on [0, 400), off [400, 600), on [600, 800), off until 4000;
//   then         on for the first 200 ms of every 4000 ms interval.
// The host decodes it in porosense.record.blinks; keep the two in step.
#pragma once
#include <stdint.h>

namespace dev {

constexpr uint8_t kSyncPin = 11;  // D11: digital only (Timer2, its PWM timer, is the sample clock)
constexpr uint16_t kSyncStartOnMs = 400;
constexpr uint16_t kSyncStartGapMs = 200;
constexpr uint16_t kSyncStartOn2Ms = 200;
constexpr uint16_t kSyncPeriodMs = 4000;
constexpr uint16_t kSyncPulseMs = 200;

// Indicator level at elapsed_ms since the stream's first sample.
bool sync_blink_on(uint32_t elapsed_ms);

class SyncBlink {
 public:
  SyncBlink() : start_us_(0), started_(false) {}
  void restart() { started_ = false; }
  // Level for the sample ticked at tick_us; the first call after restart() is time 0.
  bool level(uint32_t tick_us);

 private:
  uint32_t start_us_;
  bool started_;
};

}  // namespace dev
