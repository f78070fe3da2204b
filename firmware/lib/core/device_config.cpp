#include "device_config.h"

#include "protocol_messages.h"

namespace dev {

namespace {

uint16_t crc_step(uint16_t crc, uint8_t byte) {  // CRC-16/MCRF4XX, as on the wire
  crc ^= byte;
  for (uint8_t i = 0; i < 8; ++i) crc = (crc & 1) ? (uint16_t)((crc >> 1) ^ 0x8408) : (uint16_t)(crc >> 1);
  return crc;
}

// Slot layout (32 bytes): format, seq, rate, mask, pga|rate<<4,
// pin|r0_mode<<4|autostart bit 0<<5|line_mode<<6|autostart bit 1<<7,
// min_setpoint(2), pwm_offset(2), watchdog(2), boots(2), r0 x3 (4 each), pwm_scale(4), crc(2).
constexpr uint8_t kPayload = kConfigSlotSize - 2;

void pack(const Config& c, uint8_t seq, uint8_t* b) {
  b[0] = kConfigFormat;
  b[1] = seq;
  b[2] = c.sample_rate_hz;
  b[3] = c.channel_mask;
  b[4] = (uint8_t)(c.adc_pga | (c.adc_rate << 4));
  // AUTOSTART takes bits 5 and 7 (bit 7 held SCHEDULE_ENABLE, which this build keeps at 0).
  b[5] = (uint8_t)(c.pwm_pin | (c.r0_mode << 4) | ((c.autostart & 1) << 5) | (c.line_mode << 6) |
                   ((c.autostart >> 1) << 7));
  proto::put_i16(b + 6, c.min_setpoint_dkpa);
  proto::put_i16(b + 8, c.pwm_offset);
  proto::put_u16(b + 10, c.watchdog_ms);
  proto::put_u16(b + 12, c.boots);
  for (uint8_t i = 0; i < kChannels; ++i) proto::put_i32(b + 14 + 4 * i, c.r0_mohm[i]);
  proto::put_i32(b + 26, c.pwm_scale_milli);
}

void unpack(const uint8_t* b, Config* c) {
  c->sample_rate_hz = b[2];
  c->channel_mask = b[3];
  c->adc_pga = b[4] & 0x0F;
  c->adc_rate = b[4] >> 4;
  c->pwm_pin = b[5] & 0x0F;
  c->r0_mode = (b[5] >> 4) & 1;
  c->autostart = (uint8_t)(((b[5] >> 5) & 1) | ((b[5] >> 7) << 1));
  c->line_mode = (b[5] >> 6) & 1;
  c->schedule_enable = 0;
  c->min_setpoint_dkpa = proto::get_i16(b + 6);
  c->pwm_offset = proto::get_i16(b + 8);
  c->watchdog_ms = proto::get_u16(b + 10);
  c->boots = proto::get_u16(b + 12);
  for (uint8_t i = 0; i < kChannels; ++i) c->r0_mohm[i] = proto::get_i32(b + 14 + 4 * i);
  c->pwm_scale_milli = proto::get_i32(b + 26);
}

}  // namespace

void Config::set_defaults() {
  for (uint8_t key = 1; key <= proto::config::kCount; ++key) {
    proto::config::KeyInfo info;
    if (proto::config::key_info(key, &info)) set(key, info.def);
  }
  boots = 0;
}

bool Config::get(uint8_t key, int32_t* v) const {
  namespace k = proto::config;
  switch (key) {
    case k::SAMPLE_RATE_HZ:
      *v = sample_rate_hz;
      return true;
    case k::CHANNEL_MASK:
      *v = channel_mask;
      return true;
    case k::R0_MODE:
      *v = r0_mode;
      return true;
    case k::R0_CH0_MOHM:
      *v = r0_mohm[0];
      return true;
    case k::R0_CH1_MOHM:
      *v = r0_mohm[1];
      return true;
    case k::R0_CH2_MOHM:
      *v = r0_mohm[2];
      return true;
    case k::ADC_PGA:
      *v = adc_pga;
      return true;
    case k::ADC_RATE:
      *v = adc_rate;
      return true;
    case k::MIN_SETPOINT_DKPA:
      *v = min_setpoint_dkpa;
      return true;
    case k::WATCHDOG_MS:
      *v = watchdog_ms;
      return true;
    case k::AUTOSTART:
      *v = autostart;
      return true;
    case k::PWM_PIN:
      *v = pwm_pin;
      return true;
    case k::PWM_SCALE_MILLI:
      *v = pwm_scale_milli;
      return true;
    case k::PWM_OFFSET:
      *v = pwm_offset;
      return true;
    case k::LINE_MODE:
      *v = line_mode;
      return true;
    case k::SCHEDULE_ENABLE:
      *v = schedule_enable;
      return true;
    default:
      return false;
  }
}

uint8_t Config::set(uint8_t key, int32_t v) {
  namespace k = proto::config;
  k::KeyInfo info;
  if (!k::key_info(key, &info)) return proto::result::BAD_KEY;
  if (v < info.min || v > info.max) return proto::result::OUT_OF_RANGE;
  switch (key) {
    case k::SAMPLE_RATE_HZ:
      sample_rate_hz = (uint8_t)v;
      break;
    case k::CHANNEL_MASK:
      channel_mask = (uint8_t)v;
      break;
    case k::R0_MODE:
      r0_mode = (uint8_t)v;
      break;
    case k::R0_CH0_MOHM:
      r0_mohm[0] = v;
      break;
    case k::R0_CH1_MOHM:
      r0_mohm[1] = v;
      break;
    case k::R0_CH2_MOHM:
      r0_mohm[2] = v;
      break;
    case k::ADC_PGA:
      adc_pga = (uint8_t)v;
      break;
    case k::ADC_RATE:
      adc_rate = (uint8_t)v;
      break;
    case k::MIN_SETPOINT_DKPA:
      min_setpoint_dkpa = (int16_t)v;
      break;
    case k::WATCHDOG_MS:
      watchdog_ms = (uint16_t)v;
      break;
    case k::AUTOSTART:
      autostart = (uint8_t)v;
      break;
    case k::PWM_PIN:
      pwm_pin = (uint8_t)v;
      break;
    case k::PWM_SCALE_MILLI:
      pwm_scale_milli = v;
      break;
    case k::PWM_OFFSET:
      pwm_offset = (int16_t)v;
      break;
    case k::LINE_MODE:
      line_mode = (uint8_t)v;
      break;
    case k::SCHEDULE_ENABLE:
      schedule_enable = (uint8_t)v;
      break;
    default:
      return proto::result::BAD_KEY;
  }
  return proto::result::OK;
}

bool ConfigStore::read_slot(uint8_t slot, Config* cfg, uint8_t* seq) {
  uint8_t b[kConfigSlotSize];
  const uint16_t base = (uint16_t)(kConfigBase + slot * kConfigSlotSize);
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < kConfigSlotSize; ++i) {
    b[i] = hal_.eeprom_read((uint16_t)(base + i));
    if (i < kPayload) crc = crc_step(crc, b[i]);
  }
  if (b[0] != kConfigFormat || proto::get_u16(b + kPayload) != crc) return false;
  Config c;
  unpack(b, &c);
  // Every value must still satisfy the catalogue's limits; otherwise the slot is corrupt.
  for (uint8_t key = 1; key <= proto::config::kCount; ++key) {
    int32_t v;
    Config probe = c;
    if (!c.get(key, &v) || probe.set(key, v) != proto::result::OK) return false;
  }
  *cfg = c;
  *seq = b[1];
  return true;
}

bool ConfigStore::load(Config* cfg) {
  Config a, b;
  uint8_t sa = 0, sb = 0;
  const bool va = read_slot(0, &a, &sa);
  const bool vb = read_slot(1, &b, &sb);
  if (!va && !vb) {
    cfg->set_defaults();
    seq_ = 0;
    slot_ = 1;  // the first save goes to slot 0
    return false;
  }
  // Sequence numbers wrap: b is newer when it is ahead by less than half the range.
  const bool use_b = vb && (!va || (uint8_t)(sb - sa) < 128);
  *cfg = use_b ? b : a;
  seq_ = use_b ? sb : sa;
  slot_ = use_b ? 1 : 0;
  return true;
}

void ConfigStore::save(const Config& cfg) {
  uint8_t b[kConfigSlotSize];
  const uint8_t target = (uint8_t)(slot_ ^ 1);
  const uint8_t seq = (uint8_t)(seq_ + 1);
  pack(cfg, seq, b);
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < kPayload; ++i) crc = crc_step(crc, b[i]);
  proto::put_u16(b + kPayload, crc);
  const uint16_t base = (uint16_t)(kConfigBase + target * kConfigSlotSize);
  // Invalidate first so a torn write never leaves a slot whose old CRC matches new bytes.
  hal_.eeprom_write(base, 0xFF);
  for (uint8_t i = 1; i < kConfigSlotSize; ++i) hal_.eeprom_write((uint16_t)(base + i), b[i]);
  hal_.eeprom_write(base, b[0]);
  seq_ = seq;
  slot_ = target;
}

void ConfigStore::erase() {
  hal_.eeprom_write(kConfigBase, 0xFF);
  hal_.eeprom_write(kConfigBase + kConfigSlotSize, 0xFF);
  seq_ = 0;
  slot_ = 1;
}

}  // namespace dev
