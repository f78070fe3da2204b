// Work that must go on while a driver waits (an ADC conversion, the BNO055 boot): feed the
// AVR watchdog and move received serial bytes into the frame decoder so the 64-byte UART
// buffer never overflows during a sample. Set once by main.cpp.
#pragma once

namespace idle {
typedef void (*Hook)();
void set_hook(Hook hook);
void run();  // call from every wait loop

// Sleeps (SLEEP_MODE_IDLE) until the next interrupt unless work_pending() or a received
// byte says there is work. Every wake-up source is an interrupt: UART receive, Timer0
// overflow (millis, every 1.024 ms), Timer2 (the 1 kHz sample clock), UART transmit and
// TWI, so a sleep lasts at most ~1 ms and the AVR watchdog (1 s) is fed in time. Only the
// main loop sleeps: a driver's wait (an ADC conversion of ~1.2 ms) would overshoot by up to
// a timer period.
typedef bool (*WorkCheck)();
void sleep(WorkCheck work_pending);
}  // namespace idle
