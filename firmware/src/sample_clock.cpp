#include "sample_clock.h"

#include <Arduino.h>
#include <util/atomic.h>

#include "rate_divider.h"

namespace sample_clock {
namespace {
dev::RateDivider g_divider;
volatile uint8_t g_pending = 0;
volatile uint32_t g_tick_us = 0;
}  // namespace

void begin() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TCCR2A = _BV(WGM21);  // CTC, TOP = OCR2A
    TCCR2B = _BV(CS22);   // clk / 64 -> 250 kHz
    OCR2A = 249;          // 1 kHz
    TCNT2 = 0;
    TIFR2 = _BV(OCF2A);
    TIMSK2 = _BV(OCIE2A);
  }
}

void set_rate(uint16_t rate_hz) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_divider.set_rate(rate_hz);
    g_pending = 0;
  }
}

uint8_t take(uint32_t* tick_us) {
  uint8_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    n = g_pending;
    g_pending = 0;
    *tick_us = g_tick_us;
  }
  return n;
}

bool pending() { return g_pending != 0; }  // one byte: read atomically

}  // namespace sample_clock

ISR(TIMER2_COMPA_vect) {
  if (sample_clock::g_divider.tick()) {
    sample_clock::g_tick_us = micros();
    if (sample_clock::g_pending != 0xFF) ++sample_clock::g_pending;
  }
}
