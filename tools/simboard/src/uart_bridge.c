/* simavr raises UART_IRQ_OUTPUT for each byte the firmware transmits and accepts bytes on
 * UART_IRQ_INPUT into a 64-byte fifo; XOFF says that fifo is full, XON that it has room.
 * Bytes from the TCP client are fed only while XON holds and no faster than the line
 * (10 bits per byte at the baud rate), so the firmware sees a real serial line. */
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <arpa/inet.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>
#include "avr_uart.h"
#include "board.h"
#include "uart_bridge.h"

static uint32_t ring_count(const byte_ring_t* r) { return r->head - r->tail; }

static int ring_put(byte_ring_t* r, uint8_t b) {
  if (ring_count(r) >= UART_BUF) return 0;
  r->data[r->head++ % UART_BUF] = b;
  return 1;
}

static void on_output(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  uart_bridge_t* u = (uart_bridge_t*)param;
  u->tx_bytes++;
  if (u->client_fd < 0 || !ring_put(&u->to_host, (uint8_t)value))
    u->dropped_bytes++; /* nobody listening: the bytes are lost, as on a real port */
}

static void on_xon(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)value;
  ((uart_bridge_t*)param)->xoff = 0;
}

static void on_xoff(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)value;
  ((uart_bridge_t*)param)->xoff = 1;
}

void uart_bridge_configure(uart_bridge_t* u) {
  uint32_t flags = 0;
  avr_ioctl(u->avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(u->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  u->xoff = 0;
}

int uart_bridge_init(uart_bridge_t* u, avr_t* avr, uint16_t port, unsigned baud) {
  memset(u, 0, sizeof(*u));
  u->avr = avr;
  u->client_fd = -1;
  u->cycles_per_byte = (double)BOARD_FREQUENCY_HZ * 10.0 / baud;
  u->irq_input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  avr_irq_t* out = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
  avr_irq_t* xon = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON);
  avr_irq_t* xoff = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF);
  if (!u->irq_input || !out || !xon || !xoff) {
    errno = ENODEV;
    return -1;
  }
  avr_irq_register_notify(out, on_output, u);
  avr_irq_register_notify(xon, on_xon, u);
  avr_irq_register_notify(xoff, on_xoff, u);
  uart_bridge_configure(u);

  u->listen_fd = socket(AF_INET, SOCK_STREAM, 0);
  if (u->listen_fd < 0) return -1;
  int one = 1;
  setsockopt(u->listen_fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  struct sockaddr_in sa;
  memset(&sa, 0, sizeof sa);
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  sa.sin_port = htons(port);
  if (bind(u->listen_fd, (struct sockaddr*)&sa, sizeof sa) < 0 || listen(u->listen_fd, 1) < 0) return -1;
  socklen_t len = sizeof sa;
  getsockname(u->listen_fd, (struct sockaddr*)&sa, &len);
  u->port = ntohs(sa.sin_port);
  fcntl(u->listen_fd, F_SETFL, O_NONBLOCK);
  return 0;
}

static void drop_client(uart_bridge_t* u) {
  close(u->client_fd);
  u->client_fd = -1;
  u->to_avr.head = u->to_avr.tail = 0;
  u->to_host.head = u->to_host.tail = 0;
}

static void accept_client(uart_bridge_t* u) {
  int fd = accept(u->listen_fd, NULL, NULL);
  if (fd < 0) return;
  if (u->client_fd >= 0) drop_client(u); /* a new opener takes over the port */
  fcntl(fd, F_SETFL, O_NONBLOCK);
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  u->client_fd = fd;
  u->connections++;
  u->connected_since_poll = 1;
}

static void receive_from_host(uart_bridge_t* u) {
  uint8_t buf[4096];
  while (u->client_fd >= 0) {
    uint32_t room = UART_BUF - ring_count(&u->to_avr);
    if (room == 0) return; /* TCP flow control holds the host back */
    ssize_t n = recv(u->client_fd, buf, room < sizeof buf ? room : sizeof buf, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
      drop_client(u);
      return;
    }
    if (n < 0) return;
    for (ssize_t i = 0; i < n; i++) ring_put(&u->to_avr, buf[i]);
  }
}

static void send_to_host(uart_bridge_t* u) {
  while (u->client_fd >= 0 && ring_count(&u->to_host)) {
    uint32_t start = u->to_host.tail % UART_BUF;
    uint32_t n = ring_count(&u->to_host);
    if (n > UART_BUF - start) n = UART_BUF - start;
    ssize_t k = send(u->client_fd, u->to_host.data + start, n, MSG_NOSIGNAL);
    if (k < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) drop_client(u);
      return;
    }
    u->to_host.tail += (uint32_t)k;
  }
}

void uart_bridge_poll(uart_bridge_t* u, uint64_t now) {
  u->connected_since_poll = 0;
  accept_client(u);
  receive_from_host(u);
  if (now > u->last_feed_cycle) u->budget += (double)(now - u->last_feed_cycle) / u->cycles_per_byte;
  u->last_feed_cycle = now;
  if (u->budget > 64.0) u->budget = 64.0;
  while (!u->xoff && u->budget >= 1.0 && ring_count(&u->to_avr)) {
    uint8_t b = u->to_avr.data[u->to_avr.tail++ % UART_BUF];
    u->budget -= 1.0;
    u->rx_bytes++;
    avr_raise_irq(u->irq_input, b);
  }
  send_to_host(u);
}

void uart_bridge_close(uart_bridge_t* u) {
  if (u->client_fd >= 0) {
    send_to_host(u);
    close(u->client_fd);
  }
  if (u->listen_fd >= 0) close(u->listen_fd);
  u->client_fd = u->listen_fd = -1;
}
