// Work that must go on while a driver waits (an ADC conversion, the BNO055 boot): feed the
// AVR watchdog and move received serial bytes into the frame decoder so the 64-byte UART
// buffer never overflows during a sample. Set once by main.cpp.
#pragma once

namespace idle {
typedef void (*Hook)();
void set_hook(Hook hook);
void run();  // call from every wait loop
}  // namespace idle
