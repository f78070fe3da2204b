#include "idle.h"

#include <Arduino.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#include "uart.h"

namespace idle {
namespace {
Hook g_hook = nullptr;
bool g_running = false;  // no nesting: the hook may itself wait on nothing
}  // namespace

void set_hook(Hook hook) { g_hook = hook; }

void run() {
  wdt_reset();
  if (g_hook && !g_running) {
    g_running = true;
    g_hook();
    g_running = false;
  }
}
void sleep(WorkCheck work_pending) {
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  // Checked with interrupts off: an interrupt after the check stays pending, and the
  // instruction after sei() (the sleep) always runs before it, so it wakes the CPU at once.
  if (!work_pending() && !uart::available()) {
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
  }
  sei();
}
}  // namespace idle
