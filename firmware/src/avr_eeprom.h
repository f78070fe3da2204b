// est::Eeprom on the ATmega328P's 1 KB EEPROM (avr-libc). Writes skip unchanged bytes and
// feed the AVR watchdog: a 112-byte model chunk takes ~0.4 s of 3.4 ms byte writes.
#pragma once
#include <stdint.h>

#include "model_store.h"

class AvrEeprom : public est::Eeprom {
 public:
  uint8_t read(uint16_t addr) PORT_OVERRIDE;
  void write(uint16_t addr, uint8_t value) PORT_OVERRIDE;
  void read_block(uint16_t addr, uint8_t* dst, uint8_t n) PORT_OVERRIDE;
};
