/* UART0 of the AVR bridged to one TCP client on 127.0.0.1 (pyserial's socket://). */
#ifndef SIMBOARD_UART_BRIDGE_H
#define SIMBOARD_UART_BRIDGE_H

#include <stdint.h>
#include "sim_avr.h"

#define UART_BUF 65536

typedef struct byte_ring_t {
  uint8_t data[UART_BUF];
  uint32_t head, tail; /* head - tail bytes stored */
} byte_ring_t;

typedef struct uart_bridge_t {
  avr_t* avr;
  avr_irq_t* irq_input;
  int xoff; /* simavr's input fifo is full: hold back */
  int listen_fd, client_fd;
  uint16_t port;
  byte_ring_t to_avr, to_host;
  double budget; /* bytes the line may still deliver (paced at the baud rate) */
  double cycles_per_byte;
  uint64_t last_feed_cycle;
  uint64_t rx_bytes, tx_bytes, dropped_bytes, connections;
  int connected_since_poll; /* a client connected during the last poll */
} uart_bridge_t;

/* Listens on 127.0.0.1:port (0: the OS picks); returns 0 or -1 with errno set. */
int uart_bridge_init(uart_bridge_t* u, avr_t* avr, uint16_t port, unsigned baud);
/* Re-applies the UART flags (after an AVR reset). */
void uart_bridge_configure(uart_bridge_t* u);
/* Accepts a client, moves bytes both ways, feeds the AVR as the baud rate allows. */
void uart_bridge_poll(uart_bridge_t* u, uint64_t now_cycles);
void uart_bridge_close(uart_bridge_t* u);

#endif
