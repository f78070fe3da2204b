// Direct register access for the Uno's digital pins 0..19 and the PWM pins the board uses,
// without the Arduino core's pin tables (smaller and faster than digitalWrite/analogWrite).
// Pin n is PORTD bit n (0..7), PORTB bit n-8 (8..13), PORTC bit n-14 (14..19 = A0..A5).
#pragma once
#include <avr/io.h>
#include <stdint.h>

namespace gpio {

inline volatile uint8_t& port(uint8_t pin) { return pin < 8 ? PORTD : pin < 14 ? PORTB : PORTC; }
inline volatile uint8_t& ddr(uint8_t pin) { return pin < 8 ? DDRD : pin < 14 ? DDRB : DDRC; }
inline volatile uint8_t& input(uint8_t pin) { return pin < 8 ? PIND : pin < 14 ? PINB : PINC; }
inline uint8_t mask(uint8_t pin) { return (uint8_t)(1u << (pin < 8 ? pin : pin < 14 ? pin - 8 : pin - 14)); }

inline void write(uint8_t pin, bool high) {
  if (high)
    port(pin) |= mask(pin);
  else
    port(pin) &= (uint8_t)~mask(pin);
}
inline bool read(uint8_t pin) { return input(pin) & mask(pin); }
inline void output(uint8_t pin) { ddr(pin) |= mask(pin); }
inline void input_pullup(uint8_t pin) {
  ddr(pin) &= (uint8_t)~mask(pin);
  port(pin) |= mask(pin);
}

// PWM duty 0..255 on D5/D6 (Timer0, fast PWM, 977 Hz) or D9/D10 (Timer1, phase-correct
// 8-bit, 490 Hz), as set up by the Arduino core's init(). Duty 0 disconnects the timer and
// drives the pin low (fast PWM would still emit a one-count spike). Other pins: low/high.
void pwm(uint8_t pin, uint8_t duty);

}  // namespace gpio
