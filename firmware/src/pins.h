// Board pins of the porosense Uno shield (the simboard observes the same pins).
// Change them here to rewire; keep the regulator pins on PWM-capable pins driven by
// Timer0 (D5, D6) or Timer1 (D9, D10): Timer2 is the sampling clock.
#pragma once
#include <stdint.h>

namespace pins {

// Functions rather than arrays: an array indexed at run time would be copied to RAM.
// Pumps D2, D4, D7: HIGH = pump on.
inline uint8_t pump(uint8_t ch) { return ch == 0 ? 2 : ch == 1 ? 4 : 7; }
// Valves D8, D12, D13: HIGH = chamber connected to vacuum, LOW = vented.
inline uint8_t valve(uint8_t ch) { return ch == 0 ? 8 : ch == 1 ? 12 : 13; }
// Regulator setpoints D5, D6, D9: PWM duty = setpoint / -80 kPa * 255.
inline uint8_t regulator(uint8_t ch) { return ch == 0 ? 5 : ch == 1 ? 6 : 9; }
// D11: camera sync indicator LED, HIGH = on; the core drives it (lib/core/sync_blink.h, kSyncPin).

constexpr uint8_t kAds1115Addr = 0x48;  // ADDR pin to GND; AIN0..AIN2 single-ended
constexpr uint8_t kBno055Addr = 0x28;   // COM3 low
constexpr uint32_t kBaud = 115200;      // UART 8N1
constexpr uint32_t kI2cHz = 400000;

}  // namespace pins
