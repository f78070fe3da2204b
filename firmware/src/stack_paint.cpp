#include "stack_paint.h"

#include <avr/io.h>
#include <avr/wdt.h>

extern uint8_t _end;     // first byte after .bss (linker symbol)
extern uint8_t __stack;  // top of RAM (linker symbol)

namespace {
constexpr uint8_t kPaint = 0xC5;
uint8_t g_mcusr __attribute__((section(".noinit")));
}  // namespace

// .init1 runs before the stack pointer is used: fill [_end, __stack] with the pattern.
extern "C" void stack_paint_init1() __attribute__((naked, used, section(".init1")));
extern "C" void stack_paint_init1() {
  __asm__ volatile(
      "    ldi r30, lo8(_end)\n"
      "    ldi r31, hi8(_end)\n"
      "    ldi r24, %0\n"
      "    ldi r25, hi8(__stack)\n"
      "1:  st Z+, r24\n"
      "    cpi r30, lo8(__stack)\n"
      "    cpc r31, r25\n"
      "    brlo 1b\n"
      "    breq 1b\n"
      :
      : "i"(kPaint)
      : "r24", "r25", "r30", "r31", "memory");
}

// .init3: after the stack is set up, before constructors. A watchdog reset leaves the
// watchdog running with its shortest timeout; stop it before anything slow happens.
extern "C" void stack_paint_init3() __attribute__((naked, used, section(".init3")));
extern "C" void stack_paint_init3() {
  g_mcusr = MCUSR;
  MCUSR = 0;
  wdt_disable();
}

namespace stack_paint {

uint16_t untouched_bytes() {
  const uint8_t* p = &_end;
  uint16_t n = 0;
  while (p <= &__stack && *p == kPaint) {
    ++p;
    ++n;
  }
  return n;
}

uint8_t reset_cause() { return g_mcusr; }

}  // namespace stack_paint
