// Decoder timing on the ATmega328P (16 MHz), run in simavr by avr_cycles.c. Before each
// timed call the program writes the case number to PORTB and afterwards 0, so the harness
// can count the cycles in between. Cases: 1 a valid SAMPLE frame's delimiter; 2 a bad
// 129-byte chunk of 0x01 (every suffix is a valid COBS chain: the longest search);
// 3 the delimiter after 90 bytes of garbage and a valid SAMPLE (a recovery);
// 4 encoding one SAMPLE frame; 5 one ordinary (non-delimiter) byte; 6 a 129-byte chunk
// built so that every suffix passes the COBS and length checks (adversarial).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "frame_codec.h"

using namespace proto;

static FrameDecoder dec;
static uint8_t frame[kMaxFrameLen];
static volatile uint8_t sink;

static inline void mark(uint8_t c) { PORTB = c; }

int main() {
  DDRB = 0xFF;
  uint8_t payload[Sample::kMinLen];
  for (uint8_t i = 0; i < sizeof payload; ++i) payload[i] = (uint8_t)(i * 29 + 3);
  mark(4);
  uint8_t n = encode_frame(msg::SAMPLE, 7, payload, sizeof payload, frame);
  mark(0);
  for (uint8_t i = 0; i + 1 < n; ++i) dec.feed(frame[i]);
  mark(1);
  sink = dec.feed(0);
  mark(0);

  for (uint8_t i = 0; i < kMaxFrameLen; ++i) dec.feed(0x01);
  mark(2);
  sink = dec.feed(0);
  mark(0);

  uint16_t x = 12345;
  for (uint8_t i = 0; i < 90; ++i) {
    x = (uint16_t)(x * 75 + 74);
    dec.feed((uint8_t)((x >> 8) | 1));
  }
  for (uint8_t i = 0; i + 1 < n; ++i) dec.feed(frame[i]);
  mark(3);
  sink = dec.feed(0);
  mark(0);

  mark(5);
  sink = dec.feed(0x42);
  mark(0);

  // Every suffix is a valid COBS chain and carries a length byte that fits it.
  for (uint8_t p = 0; p < kMaxFrameLen; ++p) {
    const uint8_t ramp = (uint8_t)(kMaxFrameLen - p - 3);
    dec.feed(p + 3 == kMaxFrameLen ? 3 : (p + 3 > kMaxFrameLen ? 1 : ramp));
  }
  mark(6);
  sink = dec.feed(0);
  mark(0);
  cli();
  sleep_cpu();  // simavr stops here
}
