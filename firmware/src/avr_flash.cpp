#include "avr_flash.h"

#include <avr/pgmspace.h>

void AvrFlash::read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
  memcpy_P(dst, reinterpret_cast<const void*>(est::layout::kFlashBase + addr), n);
}
