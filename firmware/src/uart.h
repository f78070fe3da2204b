// USART0 with interrupt-driven 64-byte receive and transmit rings (63 bytes usable each, as
// the Arduino core's HardwareSerial, whose vtables, Stream layer and 157 B object it replaces).
#pragma once
#include <stdint.h>

namespace uart {

void begin(uint32_t baud);  // 8N1, double speed (UBRR rounded as the Arduino core does)
uint8_t available();        // received bytes waiting
int16_t read();             // the next received byte, -1 when none
uint8_t tx_free();          // bytes write() takes without waiting
// Queues n bytes, waiting for room when the ring is full (polling the data register when
// interrupts are off, so it never waits forever).
void write(const uint8_t* data, uint8_t n);
void flush();  // waits until the last queued byte has left the shift register

}  // namespace uart
