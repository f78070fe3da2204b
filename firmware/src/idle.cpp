#include "idle.h"

#include <avr/wdt.h>

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
}  // namespace idle
