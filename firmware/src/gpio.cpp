#include "gpio.h"

namespace gpio {

void pwm(uint8_t pin, uint8_t duty) {
  output(pin);
  volatile uint8_t* tccr = nullptr;
  uint8_t com = 0;
  switch (pin) {
    case 5:
      tccr = &TCCR0A;
      com = _BV(COM0B1);
      OCR0B = duty;
      break;
    case 6:
      tccr = &TCCR0A;
      com = _BV(COM0A1);
      OCR0A = duty;
      break;
    case 9:
      tccr = &TCCR1A;
      com = _BV(COM1A1);
      OCR1A = duty;
      break;
    case 10:
      tccr = &TCCR1A;
      com = _BV(COM1B1);
      OCR1B = duty;
      break;
    default:
      write(pin, duty >= 128);
      return;
  }
  if (duty == 0) {
    *tccr &= (uint8_t)~com;
    write(pin, false);
  } else {
    *tccr |= com;
  }
}

}  // namespace gpio
