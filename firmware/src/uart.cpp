#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>

namespace uart {
namespace {
constexpr uint8_t kRing = 64;  // a power of two: indices wrap with a mask
uint8_t g_rx[kRing], g_tx[kRing];
volatile uint8_t g_rx_head, g_rx_tail, g_tx_head, g_tx_tail;
bool g_written;  // a byte was ever queued: flush() has something to wait for

// Moves one queued byte into the data register; the UDRE interrupt stops when none is left.
void tx_one() {
  const uint8_t t = g_tx_tail;
  UDR0 = g_tx[t];
  g_tx_tail = (uint8_t)((t + 1) & (kRing - 1));
  UCSR0A = (uint8_t)((UCSR0A & ((1 << U2X0) | (1 << MPCM0))) | (1 << TXC0));  // clear TXC
  if (g_tx_head == g_tx_tail) UCSR0B &= (uint8_t) ~(1 << UDRIE0);
}
}  // namespace

void begin(uint32_t baud) {
  UCSR0A = 1 << U2X0;
  UBRR0 = (uint16_t)((F_CPU / 4 / baud - 1) / 2);
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00);  // 8N1
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
}

uint8_t available() { return (uint8_t)((g_rx_head - g_rx_tail) & (kRing - 1)); }

int16_t read() {
  const uint8_t t = g_rx_tail;
  if (g_rx_head == t) return -1;
  const uint8_t c = g_rx[t];
  g_rx_tail = (uint8_t)((t + 1) & (kRing - 1));
  return c;
}

uint8_t tx_free() { return (uint8_t)((g_tx_tail - g_tx_head - 1) & (kRing - 1)); }

void write(const uint8_t* data, uint8_t n) {
  g_written = true;
  while (n--) {
    const uint8_t next = (uint8_t)((g_tx_head + 1) & (kRing - 1));
    while (next == g_tx_tail) {
      // Full: with interrupts off nothing would drain the ring, so send from here.
      if (!(SREG & (1 << SREG_I)) && (UCSR0A & (1 << UDRE0))) tx_one();
    }
    g_tx[g_tx_head] = *data++;
    const uint8_t s = SREG;
    cli();
    g_tx_head = next;
    UCSR0B |= (uint8_t)(1 << UDRIE0);
    SREG = s;
  }
}

void flush() {
  if (!g_written) return;
  while ((UCSR0B & (1 << UDRIE0)) || !(UCSR0A & (1 << TXC0))) {
    if (!(SREG & (1 << SREG_I)) && (UCSR0B & (1 << UDRIE0)) && (UCSR0A & (1 << UDRE0))) tx_one();
  }
}

}  // namespace uart

ISR(USART_RX_vect) {
  const bool parity_error = (UCSR0A & (1 << UPE0)) != 0;  // status before data
  const uint8_t c = UDR0;
  if (parity_error) return;  // dropped, as the Arduino core does
  const uint8_t h = uart::g_rx_head, next = (uint8_t)((h + 1) & (uart::kRing - 1));
  if (next != uart::g_rx_tail) {  // full: the byte is lost (the protocol's CRC notices)
    uart::g_rx[h] = c;
    uart::g_rx_head = next;
  }
}

ISR(USART_UDRE_vect) { uart::tx_one(); }
