// Bring-up firmware for the simboard: drives the virtual sensors through Arduino's Wire
// library and answers one text line per command on the serial port (115200 8N1).
//   e<text>        echo                         -> e<text>
//   a<cfg>         ADS1115 single shot (cfg hex) -> a <code> <us> <polls> <first_os>
//   c<cfg>         write ADS1115 config only     -> c <status>
//   r<ptr>         read an ADS1115 register      -> r <value hex> <micros> | r ERR <status>
//   b              BNO055 ids and pages          -> b <chip> <page> <p1 reg7> <p1 reg8> <page>
//   m<mode>        BNO055 OPR_MODE switch, timed -> m <us> <polls> | m ERR <status>
//   u              BNO055 Euler and status       -> u <heading> <roll> <pitch> <calib> <sys>
//   p<mask>        pumps D2 D4 D7, valves D8 D12 D13 from mask bits 0..5 -> p OK
//   o<pin>,<duty>  analogWrite                   -> o OK
//   W<addr>,<n>,<v> write n EEPROM bytes of v    -> W OK
//   R<addr>        read one EEPROM byte          -> R <value>
//   t              uptime                        -> t <ms>
//   z              watchdog reset
//   i<0|1>         sleep (idle mode) while waiting for input -> i OK
#include <Arduino.h>
#include <Wire.h>
#include <avr/eeprom.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <stdlib.h>

static const uint8_t kAds = 0x48, kBno = 0x28;
static const uint8_t kPumps[3] = {2, 4, 7}, kValves[3] = {8, 12, 13};
static uint8_t reset_cause __attribute__((section(".noinit")));

// After a watchdog reset the watchdog stays on: turn it off before the C runtime starts.
void early_init(void) __attribute__((naked, used, section(".init3")));
void early_init(void) {
  reset_cause = MCUSR;
  MCUSR = 0;
  wdt_disable();
}

static uint8_t reg_write(uint8_t dev, uint8_t reg, const uint8_t* data, uint8_t n) {
  Wire.beginTransmission(dev);
  Wire.write(reg);
  Wire.write(data, n);
  return Wire.endTransmission();
}

// Returns the Wire status (0 ok, 2 address NACK) or 5 when fewer bytes arrived.
static uint8_t reg_read(uint8_t dev, uint8_t reg, uint8_t* out, uint8_t n) {
  Wire.beginTransmission(dev);
  Wire.write(reg);
  uint8_t st = Wire.endTransmission(false);
  if (st) return st;
  if (Wire.requestFrom(dev, n) != n) return 5;
  for (uint8_t i = 0; i < n; i++) out[i] = Wire.read();
  return 0;
}

static uint16_t be16(const uint8_t* b) { return (uint16_t)(b[0] << 8 | b[1]); }
static int16_t le16(const uint8_t* b) { return (int16_t)(b[1] << 8 | b[0]); }

static void ads_single_shot(uint16_t cfg) {
  uint8_t b[2] = {(uint8_t)(cfg >> 8), (uint8_t)cfg};
  uint8_t st = reg_write(kAds, 1, b, 2);
  uint32_t t0 = micros();
  if (st) {
    Serial.print(F("a ERR "));
    Serial.println(st);
    return;
  }
  uint16_t polls = 0;
  int first_os = -1;
  for (;;) {
    st = reg_read(kAds, 1, b, 2);
    if (st) break;
    polls++;
    if (first_os < 0) first_os = b[0] >> 7;
    if (b[0] & 0x80) break;
  }
  uint32_t t1 = micros();
  if (!st) st = reg_read(kAds, 0, b, 2);
  if (st) {
    Serial.print(F("a ERR "));
    Serial.println(st);
    return;
  }
  Serial.print(F("a "));
  Serial.print((int16_t)be16(b));
  Serial.print(' ');
  Serial.print(t1 - t0);
  Serial.print(' ');
  Serial.print(polls);
  Serial.print(' ');
  Serial.println(first_os);
}

static void bno_ids() {
  uint8_t chip = 0, page = 0xFF, p1_7 = 0, p1_8 = 0, page_back = 0xFF, one = 1, zero = 0;
  uint8_t st = reg_read(kBno, 0x00, &chip, 1);
  if (!st) st = reg_read(kBno, 0x07, &page, 1);
  if (!st) st = reg_write(kBno, 0x07, &one, 1);
  if (!st) st = reg_read(kBno, 0x07, &p1_7, 1);
  if (!st) st = reg_read(kBno, 0x08, &p1_8, 1);
  if (!st) st = reg_write(kBno, 0x07, &zero, 1);
  if (!st) st = reg_read(kBno, 0x07, &page_back, 1);
  if (st) {
    Serial.print(F("b ERR "));
    Serial.println(st);
    return;
  }
  Serial.print(F("b "));
  Serial.print(chip, HEX);
  Serial.print(' ');
  Serial.print(page);
  Serial.print(' ');
  Serial.print(p1_7);
  Serial.print(' ');
  Serial.print(p1_8, HEX);
  Serial.print(' ');
  Serial.println(page_back);
}

static void bno_mode(uint8_t mode) {
  uint8_t st = reg_write(kBno, 0x3D, &mode, 1);
  uint32_t t0 = micros();
  uint16_t polls = 0;
  uint8_t now = 0xFF;
  while (!st) {
    st = reg_read(kBno, 0x3D, &now, 1);
    polls++;
    if (now == mode || polls > 60000) break;
  }
  uint32_t t1 = micros();
  if (st) {
    Serial.print(F("m ERR "));
    Serial.println(st);
    return;
  }
  Serial.print(F("m "));
  Serial.print(t1 - t0);
  Serial.print(' ');
  Serial.println(polls);
}

static void bno_euler() {
  uint8_t e[6], calib = 0, sys = 0;
  uint8_t st = reg_read(kBno, 0x1A, e, 6);
  if (!st) st = reg_read(kBno, 0x35, &calib, 1);
  if (!st) st = reg_read(kBno, 0x39, &sys, 1);
  if (st) {
    Serial.print(F("u ERR "));
    Serial.println(st);
    return;
  }
  Serial.print(F("u "));
  for (uint8_t i = 0; i < 3; i++) {
    Serial.print(le16(e + 2 * i));
    Serial.print(' ');
  }
  Serial.print(calib, HEX);
  Serial.print(' ');
  Serial.println(sys);
}

static bool idle_sleep;
static char line[64];
static uint8_t line_len;

static void handle(char* s) {
  char cmd = s[0];
  char* arg = s + 1;
  switch (cmd) {
    case 'e':
      Serial.println(s);
      break;
    case 'a':
      ads_single_shot((uint16_t)strtoul(arg, 0, 16));
      break;
    case 'c': {
      uint16_t cfg = (uint16_t)strtoul(arg, 0, 16);
      uint8_t b[2] = {(uint8_t)(cfg >> 8), (uint8_t)cfg};
      Serial.print(F("c "));
      Serial.println(reg_write(kAds, 1, b, 2));
      break;
    }
    case 'r': {
      uint8_t b[2];
      uint8_t st = reg_read(kAds, (uint8_t)strtoul(arg, 0, 16), b, 2);
      Serial.print(F("r "));
      if (st) {
        Serial.print(F("ERR "));
        Serial.println(st);
      } else {
        Serial.print(be16(b), HEX);
        Serial.print(' ');
        Serial.println(micros());
      }
      break;
    }
    case 'b':
      bno_ids();
      break;
    case 'm':
      bno_mode((uint8_t)strtoul(arg, 0, 16));
      break;
    case 'u':
      bno_euler();
      break;
    case 'p': {
      uint8_t mask = (uint8_t)strtoul(arg, 0, 16);
      for (uint8_t i = 0; i < 3; i++) {
        digitalWrite(kPumps[i], (mask >> i) & 1);
        digitalWrite(kValves[i], (mask >> (i + 3)) & 1);
      }
      Serial.println(F("p OK"));
      break;
    }
    case 'o': {
      char* rest;
      uint8_t pin = (uint8_t)strtoul(arg, &rest, 10);
      uint8_t duty = (uint8_t)strtoul(rest + 1, 0, 10);
      analogWrite(pin, duty);
      Serial.println(F("o OK"));
      break;
    }
    case 'W': {
      char* rest;
      uint16_t addr = (uint16_t)strtoul(arg, &rest, 10);
      uint16_t n = (uint16_t)strtoul(rest + 1, &rest, 10);
      uint8_t v = (uint8_t)strtoul(rest + 1, 0, 10);
      for (uint16_t i = 0; i < n; i++) eeprom_write_byte((uint8_t*)(addr + i), v);
      Serial.println(F("W OK"));
      break;
    }
    case 'R':
      Serial.print(F("R "));
      Serial.println(eeprom_read_byte((const uint8_t*)strtoul(arg, 0, 10)));
      break;
    case 't':
      Serial.print(F("t "));
      Serial.println(millis());
      break;
    case 'i':
      idle_sleep = arg[0] == '1';
      Serial.println(F("i OK"));
      break;
    case 'z':
      Serial.flush();
      wdt_enable(WDTO_15MS);
      for (;;) {
      }
    default:
      Serial.println(F("?"));
  }
}

void setup() {
  Serial.begin(115200);
  for (uint8_t i = 0; i < 3; i++) {
    pinMode(kPumps[i], OUTPUT);
    pinMode(kValves[i], OUTPUT);
  }
  Wire.begin();
  Wire.setClock(400000);
  Serial.print(F("boot "));
  Serial.println(reset_cause, HEX);
}

void loop() {
  if (idle_sleep && !Serial.available()) {
    // the timer 0 tick or the next received byte wakes us
    set_sleep_mode(SLEEP_MODE_IDLE);
    sleep_mode();
  }
  while (Serial.available()) {
    char c = (char)Serial.read();
    if (c == '\r') continue;
    if (c == '\n') {
      line[line_len] = 0;
      if (line_len) handle(line);
      line_len = 0;
    } else if (line_len < sizeof(line) - 1) {
      line[line_len++] = c;
    }
  }
}
