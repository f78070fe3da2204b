/* The board's monotonic clock in cycles, kept apart from the harness's main loop so that the
 * virtual sensors and the loop both depend on it and not on each other. */
#include "board.h"

static const avr_t* clock_avr;
uint64_t board_cycle_base;

void board_clock_attach(const avr_t* avr) { clock_avr = avr; }

uint64_t board_cycles(void) { return board_cycle_base + clock_avr->cycle; }
