#include "control_store.h"

#include "frame_codec.h"
#include "protocol_messages.h"

namespace dev {

namespace r = proto::result;

namespace {

constexpr uint8_t kGainsMagic = 'G', kTrajMagic = 'T';

bool newer(uint8_t a, uint8_t b) { return (uint8_t)(a - b) < 128; }

}  // namespace

uint16_t ControlStore::read16(uint16_t addr) const {
  return (uint16_t)(hal_.eeprom_read(addr) | (hal_.eeprom_read((uint16_t)(addr + 1)) << 8));
}

uint16_t ControlStore::crc_of(uint16_t addr, uint8_t n) const {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < n; ++i) crc = proto::crc16_update(crc, hal_.eeprom_read((uint16_t)(addr + i)));
  return crc;
}

bool ControlStore::crc_ok(uint16_t addr, uint8_t n) const {
  return crc_of((uint16_t)(addr + 1), n) == read16((uint16_t)(addr + 1 + n));
}

void ControlStore::write(uint16_t addr, const uint8_t* src, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) hal_.eeprom_write((uint16_t)(addr + i), src[i]);
}

void ControlStore::boot(ctl::Gains* gains) {
  uint8_t* g = (uint8_t*)gains;
  for (uint8_t i = 0; i < ctl::kGainsBytes; ++i) g[i] = 0;
  gains_slot_ = traj_slot_ = kNoSlot;
  total_ = 0;
  for (uint8_t s = 0; s < 2; ++s) {
    const uint16_t a = (uint16_t)(kCtlBase + s * kGainsSlot);
    const uint8_t seq = hal_.eeprom_read((uint16_t)(a + 1));
    if (hal_.eeprom_read(a) == kGainsMagic && crc_ok(a, 1 + ctl::kGainsBytes) &&
        (gains_slot_ == kNoSlot || newer(seq, gains_seq_))) {
      gains_slot_ = s;
      gains_seq_ = seq;
    }
    const uint16_t t = traj_addr(s);
    const uint8_t tseq = hal_.eeprom_read((uint16_t)(t + 1));
    if (hal_.eeprom_read(t) == kTrajMagic && check_record(s, 0, false) == 0 &&
        (traj_slot_ == kNoSlot || newer(tseq, traj_seq_))) {
      traj_slot_ = s;
      traj_seq_ = tseq;
    }
  }
  if (gains_slot_ == kNoSlot) return;
  const uint16_t a = (uint16_t)(kCtlBase + gains_slot_ * kGainsSlot + 2);
  for (uint8_t i = 0; i < ctl::kGainsBytes; ++i) g[i] = hal_.eeprom_read((uint16_t)(a + i));
}

void ControlStore::save_gains(const ctl::Gains& g) {
  const uint8_t slot = gains_slot_ == 0 ? 1 : 0;
  const uint16_t a = (uint16_t)(kCtlBase + slot * kGainsSlot);
  const uint8_t seq = (uint8_t)(gains_slot_ == kNoSlot ? 0 : gains_seq_ + 1);
  hal_.eeprom_write(a, 0xFF);  // invalid while torn
  hal_.eeprom_write((uint16_t)(a + 1), seq);
  write((uint16_t)(a + 2), (const uint8_t*)&g, ctl::kGainsBytes);
  const uint16_t crc = crc_of((uint16_t)(a + 1), 1 + ctl::kGainsBytes);
  hal_.eeprom_write((uint16_t)(a + 2 + ctl::kGainsBytes), (uint8_t)crc);
  hal_.eeprom_write((uint16_t)(a + 3 + ctl::kGainsBytes), (uint8_t)(crc >> 8));
  hal_.eeprom_write(a, kGainsMagic);  // last
  gains_slot_ = slot;
  gains_seq_ = seq;
}

uint8_t ControlStore::check_record(uint8_t slot, uint8_t length, bool structure) const {
  const uint16_t a = (uint16_t)(traj_addr(slot) + 2);  // the record, after magic and seq
  const uint8_t n = hal_.eeprom_read(a);
  const uint8_t cols = hal_.eeprom_read((uint16_t)(a + 1)) & 0x7F;
  const uint8_t pb = (uint8_t)(2 + 2 * cols);
  const uint16_t len = (uint16_t)(2 + n * pb + 2);
  if (length == 0) length = len > kTrajMaxRecord ? kTrajMaxRecord : (uint8_t)len;
  if (crc_of(a, (uint8_t)(length - 2)) != read16((uint16_t)(a + length - 2))) return 1;
  if (n < 2 || (cols != 1 && cols != 3) || len != length) return 2;
  if (!structure) return 0;
  uint16_t prev = 0;
  for (uint8_t i = 0; i < n; ++i) {
    const uint16_t p = (uint16_t)(a + 2 + i * pb);
    const uint16_t t = read16(p);
    if (i == 0 ? t != 0 : (t <= prev || t - prev > 32767)) return 2;
    prev = t;
    for (uint8_t c = 0; c < cols; ++c) {
      const int16_t y = rec_at((uint16_t)(p + 2 + 2 * c));
      if (y > ctl::kTargetLimit || y < -ctl::kTargetLimit) return 2;
    }
  }
  return 0;
}

uint8_t ControlStore::chunk(uint8_t total, uint8_t offset, const uint8_t* data, uint8_t n, int16_t* detail) {
  *detail = 0;
  const uint8_t slot = traj_slot_ == 0 ? 1 : 0;
  const uint16_t a = traj_addr(slot);
  if (offset == 0) {
    if (total > kTrajMaxRecord) {
      *detail = (int16_t)(total - kTrajMaxRecord);
      return r::TOO_LARGE;
    }
    if (total < 12) {  // two 1-column points and the CRC at least
      *detail = 1;
      return r::BAD_MODEL;
    }
    total_ = total;
    next_ = 0;
    hal_.eeprom_write(a, 0xFF);  // the slot being written is never valid while torn
    hal_.eeprom_write((uint16_t)(a + 1), (uint8_t)(traj_slot_ == kNoSlot ? 0 : traj_seq_ + 1));
  }
  if (total_ == 0 || total != total_ || offset != next_) {
    *detail = next_;
    return r::BAD_STATE;
  }
  if ((uint16_t)offset + n > total_) {
    *detail = (int16_t)(offset + n - total_);
    return r::TOO_LARGE;
  }
  write((uint16_t)(a + 2 + offset), data, n);
  next_ = (uint8_t)(next_ + n);
  if (next_ < total_) return r::OK;
  total_ = 0;
  const uint8_t bad = check_record(slot, next_, true);
  if (bad) {
    *detail = (int16_t)(bad - 1);  // 0 CRC, 1 structure
    return r::BAD_MODEL;
  }
  traj_seq_ = hal_.eeprom_read((uint16_t)(a + 1));
  hal_.eeprom_write(a, kTrajMagic);  // last: the record counts from here on
  traj_slot_ = slot;
  return r::OK;
}

}  // namespace dev
