/* The lock-step link between the harness and the plant process (binary records on pipes).
 *
 * After a text line "SIMBOARD 1 PORT <p> FREQ <hz> PERIOD_US <us>\n" on stdout, the harness
 * writes one tick_record_t every period of AVR time and blocks until it has read one
 * reply_record_t from stdin. All fields are little-endian (x86 and ARM hosts). */
#ifndef SIMBOARD_COSIM_H
#define SIMBOARD_COSIM_H

#include <stdint.h>

#define TICK_MAGIC 0x31544253u /* "SBT1" */

enum {                           /* tick_record_t.events */
       EV_RESET = 1 << 0,        /* the AVR was reset since the previous tick */
       EV_EEPROM_SAVED = 1 << 1, /* the EEPROM image file was written */
       EV_HALTED = 1 << 2,       /* the AVR stopped (crash, or sleep with interrupts off) */
       EV_FAULT = 1 << 3,        /* a command failed (for example the EEPROM file) */
       EV_FLASHED = 1 << 4,      /* flash pages were programmed (CMD_PROGRAM_FLASH) */
};

enum { /* reply_record_t.cmd */
       CMD_NONE = 0,
       CMD_RESET = 1,       /* reset the AVR (the reset button) */
       CMD_SAVE_EEPROM = 2, /* write the EEPROM image file */
       CMD_SET_ABSENT = 3,  /* arg8 bit0: ADS1115 absent, bit1: BNO055 absent */
       CMD_QUIT = 4,
       CMD_RESET_AFTER_EE = 5, /* reset the AVR right after arg16 more EEPROM byte writes */
       CMD_POWER_CYCLE = 6,    /* reset the AVR and both sensors */
       CMD_PROGRAM_FLASH = 7,  /* an upload: program the first arg16 pages of the --flash-pages
                                * file (records: u32 address, 128 bytes) into flash, then reset */
};

#pragma pack(push, 1)
typedef struct tick_record_t {
  uint32_t magic;
  uint32_t seq;
  uint64_t cycles; /* board cycles since power-on (monotonic across resets) */
  uint16_t pins;   /* bit n: Dn driven high */
  uint8_t duty[6]; /* D3, D5, D6, D9, D10, D11: 0..255 */
  uint8_t events;
  uint8_t resets;           /* AVR resets so far, modulo 256 */
  uint16_t twi_nacks;       /* address phases not acknowledged, modulo 65536 */
  uint32_t uart_rx;         /* bytes delivered to the AVR */
  uint32_t uart_tx;         /* bytes sent by the AVR */
  uint32_t eeprom_writes;   /* EEPROM byte writes started by the firmware */
  uint32_t uart_dropped;    /* bytes sent by the AVR while no client was connected */
  uint32_t adc_conversions; /* ADS1115 conversions completed */
} tick_record_t;

typedef struct reply_record_t {
  float ain_V[4];     /* ADS1115 AIN0..AIN3 (V) */
  float euler_deg[3]; /* BNO055 heading, roll, pitch (deg) */
  uint8_t cmd;
  uint8_t arg8;
  uint16_t arg16;
} reply_record_t;
#pragma pack(pop)

_Static_assert(sizeof(tick_record_t) == 48, "tick record is 48 bytes");
_Static_assert(sizeof(reply_record_t) == 32, "reply record is 32 bytes");

#endif
