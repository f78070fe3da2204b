/* Digital pin levels and PWM duties of the Uno's D0..D13, read from the I/O registers. */
#ifndef SIMBOARD_PINS_H
#define SIMBOARD_PINS_H

#include <stdint.h>
#include "sim_avr.h"

/* Arduino PWM pins in the order of pins_state_t.duty. */
#define PINS_PWM_COUNT 6
extern const uint8_t pins_pwm_pin[PINS_PWM_COUNT]; /* 3, 5, 6, 9, 10, 11 */

typedef struct pins_state_t {
  uint16_t level;               /* bit n: Dn driven high (PORT & DDR) */
  uint8_t duty[PINS_PWM_COUNT]; /* 0..255: OCR when the timer drives the pin, else 0/255 */
} pins_state_t;

void pins_read(avr_t* avr, pins_state_t* out);

#endif
