#include "avr_eeprom.h"

#include <avr/eeprom.h>

#include "idle.h"

uint8_t AvrEeprom::read(uint16_t addr) { return eeprom_read_byte(reinterpret_cast<const uint8_t*>(addr)); }

void AvrEeprom::write(uint16_t addr, uint8_t value) {
  idle::run();  // ~3.4 ms per byte: feed the AVR watchdog, keep the link watchdog running
  eeprom_update_byte(reinterpret_cast<uint8_t*>(addr), value);
}

void AvrEeprom::read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
  eeprom_read_block(dst, reinterpret_cast<const void*>(addr), n);
}
