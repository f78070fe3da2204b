// est::FlashRom on the ATmega328P: the flash model store at the top of the application flash
// (layout::kFlashBase), written only at upload time and read with memcpy_P.
#pragma once
#include <stdint.h>

#include "model_store.h"

class AvrFlash : public est::FlashRom {
 public:
  void read_block(uint16_t addr, uint8_t* dst, uint8_t n) PORT_OVERRIDE;
};
