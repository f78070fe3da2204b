#include "twi.h"

#include <Arduino.h>
#include <util/twi.h>

#include "gpio.h"

namespace twi {

namespace {

uint8_t g_twbr = 12;  // 400 kHz
uint16_t g_timeouts = 0;
volatile uint8_t g_done = 0;

// Each bus phase starts with TWINT written 1 and TWIE set; the interrupt only records the
// completion and disables itself (TWINT stays set and holds the bus until the next phase).
// Waiting on this flag rather than on TWCR.TWINT also works in simavr 1.6, whose TWCR
// still reads TWINT = 1 right after software cleared it.
bool run_phase(uint8_t bits) {
  g_done = 0;
  TWCR = (uint8_t)(bits | _BV(TWINT) | _BV(TWEN) | _BV(TWIE));
  const uint32_t t0 = micros();
  while (!g_done) {
    if ((uint32_t)(micros() - t0) > kPhaseTimeoutUs) {
      TWCR = _BV(TWEN);  // no late interrupt
      if (g_timeouts != 0xFFFF) ++g_timeouts;
      return false;
    }
  }
  return true;
}

uint8_t status() { return TW_STATUS; }

// Clock SCL until a slave stuck in the middle of a byte releases SDA, then issue a STOP.
void recover_bus() {
  TWCR = 0;
  gpio::input_pullup(SDA);
  gpio::write(SCL, true);
  gpio::output(SCL);
  for (uint8_t i = 0; i < 9 && !gpio::read(SDA); ++i) {
    gpio::write(SCL, false);
    delayMicroseconds(5);
    gpio::write(SCL, true);
    delayMicroseconds(5);
  }
  gpio::write(SDA, false);
  gpio::output(SDA);
  delayMicroseconds(5);
  gpio::write(SCL, true);
  delayMicroseconds(5);
  gpio::write(SDA, true);  // STOP: SDA rises while SCL is high
  delayMicroseconds(5);
  gpio::input_pullup(SDA);
  gpio::input_pullup(SCL);
  TWSR = 0;
  TWBR = g_twbr;
  TWCR = _BV(TWEN);
}

void stop() {
  TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
  const uint32_t t0 = micros();
  while (TWCR & _BV(TWSTO)) {
    if ((uint32_t)(micros() - t0) > kPhaseTimeoutUs) {
      recover_bus();
      return;
    }
  }
}

bool start(uint8_t sla) {
  if (!run_phase(_BV(TWSTA))) return false;
  const uint8_t s = status();
  if (s != TW_START && s != TW_REP_START) return false;
  TWDR = sla;
  if (!run_phase(0)) return false;
  return status() == ((sla & 1) ? TW_MR_SLA_ACK : TW_MT_SLA_ACK);
}

bool send(uint8_t b) {
  TWDR = b;
  return run_phase(0) && status() == TW_MT_DATA_ACK;
}

bool receive(uint8_t* b, bool ack) {
  if (!run_phase(ack ? _BV(TWEA) : 0)) return false;
  *b = TWDR;
  return status() == (ack ? TW_MR_DATA_ACK : TW_MR_DATA_NACK);
}

}  // namespace

void begin(uint32_t scl_hz) {
  g_twbr = (uint8_t)(((F_CPU / scl_hz) - 16) / 2);
  gpio::input_pullup(SDA);
  gpio::input_pullup(SCL);
  TWSR = 0;  // prescaler 1
  TWBR = g_twbr;
  TWCR = _BV(TWEN);
}

bool probe(uint8_t addr) {
  const bool ok = start((uint8_t)(addr << 1));
  stop();
  return ok;
}

bool write_reg(uint8_t addr, uint8_t reg, const uint8_t* data, uint8_t n) {
  if (!start((uint8_t)(addr << 1)) || !send(reg)) {
    stop();
    return false;
  }
  for (uint8_t i = 0; i < n; ++i) {
    if (!send(data[i])) {
      stop();
      return false;
    }
  }
  stop();
  return true;
}

// (Repeated) start with SLA+R, n bytes (the last one NACKed), stop.
static bool read_tail(uint8_t addr, uint8_t* dst, uint8_t n) {
  if (!start((uint8_t)((addr << 1) | 1))) {
    stop();
    return false;
  }
  for (uint8_t i = 0; i < n; ++i) {
    if (!receive(dst + i, i + 1 < n)) {
      stop();
      return false;
    }
  }
  stop();
  return true;
}

bool read_reg(uint8_t addr, uint8_t reg, uint8_t* dst, uint8_t n) {
  if (!start((uint8_t)(addr << 1)) || !send(reg)) {
    stop();
    return false;
  }
  return read_tail(addr, dst, n);
}

bool read(uint8_t addr, uint8_t* dst, uint8_t n) { return read_tail(addr, dst, n); }

uint16_t timeouts() { return g_timeouts; }

}  // namespace twi

ISR(TWI_vect) {
  TWCR = _BV(TWEN);  // TWINT written 0: left set; TWIE off until the next phase
  twi::g_done = 1;
}
