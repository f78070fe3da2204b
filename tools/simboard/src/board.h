/* Shared state of the simulated porosense board (atmega328p + ADS1115 + BNO055). */
#ifndef SIMBOARD_BOARD_H
#define SIMBOARD_BOARD_H

#include <stdint.h>
#include "sim_avr.h"

#define BOARD_FREQUENCY_HZ 16000000u

/* Analog and IMU inputs the plant sets; read by the virtual sensors. */
typedef struct plant_inputs_t {
  float ain_V[4];     /* ADS1115 AIN0..AIN3 (volts, to GND) */
  float euler_deg[3]; /* BNO055 heading, roll, pitch (degrees) */
} plant_inputs_t;

/* Monotonic board time in cycles: survives AVR resets, which may zero avr->cycle. */
uint64_t board_cycles(void);
/* The AVR whose cycle counter the clock reads. */
void board_clock_attach(const avr_t* avr);
/* Cycles added to the AVR's counter: the harness raises it when a reset zeroes the counter
 * and when it skips idle time. */
extern uint64_t board_cycle_base;

static inline uint64_t board_us_to_cycles(double us) { return (uint64_t)(us * (BOARD_FREQUENCY_HZ / 1e6) + 0.5); }

#endif
