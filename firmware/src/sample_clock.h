// The sampling clock: Timer2 in CTC mode interrupts at exactly 1 kHz (16 MHz / 64 / 250) and
// a RateDivider turns that into sample ticks. Timer0 keeps millis()/micros() and the PWM on
// D5/D6, Timer1 the PWM on D9. Ticks the loop has not taken yet accumulate, so a late loop
// sees n > 1 and counts the overruns.
#pragma once
#include <stdint.h>

namespace sample_clock {
void begin();
void set_rate(uint16_t rate_hz);  // 0 stops; drops ticks not yet taken
uint8_t take(uint32_t* tick_us);  // ticks since the last take, time of the latest
bool pending();                   // a tick waits to be taken
}  // namespace sample_clock
