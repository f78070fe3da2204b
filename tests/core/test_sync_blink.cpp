// The sync indicator pattern: levels at the documented times, the start code, the periodic
// pulse, restart at each stream and the 32-bit micros() wrap.
#include <stdint.h>
#include <stdio.h>

#include "check.h"
#include "sync_blink.h"

// Level per the pattern as documented in sync_blink.h and docs/camera.md, written out as
// the list of on-intervals (ms) rather than through the constants.
static bool documented(uint32_t ms) {
  if (ms < 400) return true;
  if (ms >= 600 && ms < 800) return true;
  if (ms < 4000) return false;
  return (ms % 4000) < 200;
}

static void test_pattern() {
  int mismatches = 0;
  for (uint32_t ms = 0; ms < 200000; ++ms)
    if (dev::sync_blink_on(ms) != documented(ms)) ++mismatches;
  CHECK_MSG(mismatches == 0, "%d ms disagree with the documented pattern", mismatches);
  // Rising edges in the first 20 s: 0, 600, 4000, 8000, 12000, 16000.
  int rising = 0;
  for (uint32_t ms = 1; ms < 20000; ++ms)
    if (dev::sync_blink_on(ms) && !dev::sync_blink_on(ms - 1)) ++rising;
  CHECK_MSG(rising == 5, "rising edges after time 0: %d", rising);
  printf("sync_blink_on: %d mismatches over 200 s, %d rising edges in 20 s\n", mismatches, rising);
}

static void test_ticks_and_wrap() {
  // 50 Hz ticks starting 3 s before the 32-bit micros() wrap.
  dev::SyncBlink blink;
  const uint32_t start = 0xFFFFFFFFUL - 3000000UL + 1UL;
  int mismatches = 0;
  for (uint32_t k = 0; k < 1000; ++k) {
    const uint32_t t = start + k * 20000UL;  // wraps after 150 ticks
    if (blink.level(t) != documented(k * 20)) ++mismatches;
  }
  CHECK_MSG(mismatches == 0, "%d ticks disagree across the wrap", mismatches);
  // A new stream restarts the pattern at its first tick.
  blink.restart();
  CHECK(blink.level(123456789UL));              // time 0: on
  CHECK(!blink.level(123456789UL + 450000UL));  // 450 ms: gap of the start code
  CHECK(blink.level(123456789UL + 650000UL));   // 650 ms: second start pulse
  CHECK(!blink.level(123456789UL + 3990000UL));
  CHECK(blink.level(123456789UL + 4000000UL));
  printf("SyncBlink: %d mismatches over 1000 ticks across the micros() wrap\n", mismatches);
}

int main() {
  test_pattern();
  test_ticks_and_wrap();
  printf("test_sync_blink: %d checks, %d failures\n", g_checks, g_failures);
  return g_failures ? 1 : 0;
}
