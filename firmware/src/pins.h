// Board pins of the porosense Uno shield (the simboard observes the same pins).
// Change them here to rewire; keep the regulator pins on PWM-capable pins driven by
// Timer0 (D5, D6) or Timer1 (D9, D10): Timer2 is the sampling clock.
#pragma once
#include <stdint.h>

namespace pins {

constexpr uint8_t kPump[3] = {2, 4, 7};        // HIGH = pump on
constexpr uint8_t kValve[3] = {8, 12, 13};     // HIGH = chamber to vacuum, LOW = vented
constexpr uint8_t kRegulator[3] = {5, 6, 9};   // PWM duty = setpoint / -80 kPa * 255

constexpr uint8_t kAds1115Addr = 0x48;         // ADDR pin to GND; AIN0..AIN2 single-ended
constexpr uint8_t kBno055Addr = 0x28;          // COM3 low
constexpr uint32_t kBaud = 115200;             // UART 8N1
constexpr uint32_t kI2cHz = 400000;

}  // namespace pins
