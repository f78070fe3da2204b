/* Arduino's analogWrite() connects a timer's compare output to the pin (COMnx1 set) and
 * writes the OCR register; 0 and 255 disconnect it and drive the pin low or high. The duty
 * is therefore OCR/255 while the compare output is connected, otherwise the pin level. */
#include "pins.h"

/* data-space addresses of the atmega328p I/O registers */
enum {
  R_DDRB = 0x24,
  R_PORTB = 0x25,
  R_DDRD = 0x2A,
  R_PORTD = 0x2B,
  R_TCCR0A = 0x44,
  R_OCR0A = 0x47,
  R_OCR0B = 0x48,
  R_TCCR1A = 0x80,
  R_OCR1AL = 0x88,
  R_OCR1BL = 0x8A,
  R_TCCR2A = 0xB0,
  R_OCR2A = 0xB3,
  R_OCR2B = 0xB4
};

const uint8_t pins_pwm_pin[PINS_PWM_COUNT] = {3, 5, 6, 9, 10, 11};

static const struct {
  uint8_t tccr, com_bit, ocr;
} pwm_map[PINS_PWM_COUNT] = {
    {R_TCCR2A, 5, R_OCR2B},  /* D3  OC2B */
    {R_TCCR0A, 5, R_OCR0B},  /* D5  OC0B */
    {R_TCCR0A, 7, R_OCR0A},  /* D6  OC0A */
    {R_TCCR1A, 7, R_OCR1AL}, /* D9  OC1A (8-bit PWM: low byte) */
    {R_TCCR1A, 5, R_OCR1BL}, /* D10 OC1B */
    {R_TCCR2A, 7, R_OCR2A},  /* D11 OC2A */
};

void pins_read(avr_t* avr, pins_state_t* out) {
  const uint8_t* d = avr->data;
  uint8_t pd = d[R_PORTD] & d[R_DDRD];
  uint8_t pb = d[R_PORTB] & d[R_DDRB];
  out->level = (uint16_t)(pd | ((pb & 0x3F) << 8));
  for (int i = 0; i < PINS_PWM_COUNT; i++) {
    if (d[pwm_map[i].tccr] & (1u << pwm_map[i].com_bit))
      out->duty[i] = d[pwm_map[i].ocr];
    else
      out->duty[i] = (out->level >> pins_pwm_pin[i]) & 1 ? 255 : 0;
  }
}
