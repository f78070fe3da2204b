#include "twi.h"

#include <Arduino.h>
#include <util/twi.h>

namespace twi {

namespace {

uint32_t g_scl_hz = 400000;
uint16_t g_timeouts = 0;

bool wait_twint() {
  const uint32_t t0 = micros();
  while (!(TWCR & _BV(TWINT))) {
    if ((uint32_t)(micros() - t0) > kPhaseTimeoutUs) {
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
  pinMode(SDA, INPUT_PULLUP);
  pinMode(SCL, OUTPUT);
  for (uint8_t i = 0; i < 9 && digitalRead(SDA) == LOW; ++i) {
    digitalWrite(SCL, LOW);
    delayMicroseconds(5);
    digitalWrite(SCL, HIGH);
    delayMicroseconds(5);
  }
  pinMode(SDA, OUTPUT);
  digitalWrite(SDA, LOW);
  delayMicroseconds(5);
  digitalWrite(SCL, HIGH);
  delayMicroseconds(5);
  digitalWrite(SDA, HIGH);  // STOP: SDA rises while SCL is high
  delayMicroseconds(5);
  pinMode(SDA, INPUT_PULLUP);
  pinMode(SCL, INPUT_PULLUP);
  begin(g_scl_hz);
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
  TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN);
  if (!wait_twint()) return false;
  const uint8_t s = status();
  if (s != TW_START && s != TW_REP_START) return false;
  TWDR = sla;
  TWCR = _BV(TWINT) | _BV(TWEN);
  if (!wait_twint()) return false;
  return status() == ((sla & 1) ? TW_MR_SLA_ACK : TW_MT_SLA_ACK);
}

bool send(uint8_t b) {
  TWDR = b;
  TWCR = _BV(TWINT) | _BV(TWEN);
  return wait_twint() && status() == TW_MT_DATA_ACK;
}

bool receive(uint8_t* b, bool ack) {
  TWCR = _BV(TWINT) | _BV(TWEN) | (ack ? _BV(TWEA) : 0);
  if (!wait_twint()) return false;
  *b = TWDR;
  return status() == (ack ? TW_MR_DATA_ACK : TW_MR_DATA_NACK);
}

}  // namespace

void begin(uint32_t scl_hz) {
  g_scl_hz = scl_hz;
  pinMode(SDA, INPUT_PULLUP);
  pinMode(SCL, INPUT_PULLUP);
  TWSR = 0;  // prescaler 1
  TWBR = (uint8_t)(((F_CPU / scl_hz) - 16) / 2);
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

bool read_reg(uint8_t addr, uint8_t reg, uint8_t* dst, uint8_t n) {
  if (n == 0) return true;
  if (!start((uint8_t)(addr << 1)) || !send(reg) || !start((uint8_t)((addr << 1) | 1))) {
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

uint16_t timeouts() { return g_timeouts; }

}  // namespace twi
