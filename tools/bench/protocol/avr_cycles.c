/* Runs avr_decode.elf in simavr and prints the CPU cycles of each marked case as JSON.
 * Usage: avr_cycles build/avr_decode.elf */
#include <stdio.h>
#include <stdlib.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "avr_ioport.h"

static avr_t* avr;
static avr_cycle_count_t started[8];
static long cycles[8];
static int current;

static void on_portb(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  if (value != 0 && value < 8) {
    current = (int)value;
    started[current] = avr->cycle;
  } else if (value == 0 && current) {
    cycles[current] = (long)(avr->cycle - started[current]);
    current = 0;
  }
}

int main(int argc, char** argv) {
  elf_firmware_t fw = {{0}};
  if (argc < 2 || elf_read_firmware(argv[1], &fw) != 0) {
    fprintf(stderr, "usage: avr_cycles program.elf\n");
    return 2;
  }
  avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) return 2;
  avr_init(avr);
  avr->frequency = 16000000;
  avr->log = 0;
  avr_load_firmware(avr, &fw);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN_ALL), on_portb, NULL);
  int state = cpu_Running;
  for (long steps = 0; steps < 50000000L && state != cpu_Done && state != cpu_Crashed; ++steps) state = avr_run(avr);
  printf(
      "{\"f_cpu_hz\": 16000000, \"valid_frame_delimiter\": %ld, \"worst_bad_chunk_delimiter\": %ld, "
      "\"recovery_delimiter\": %ld, \"encode_sample\": %ld, \"ordinary_byte\": %ld, "
      "\"adversarial_chunk_delimiter\": %ld}\n",
      cycles[1], cycles[2], cycles[3], cycles[4], cycles[5], cycles[6]);
  return state == cpu_Crashed ? 1 : 0;
}
