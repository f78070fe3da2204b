#include "control_store.h"

#include "frame_codec.h"
#include "protocol_messages.h"

namespace dev {

namespace r = proto::result;

namespace {
inline uint8_t magic(uint8_t kind) { return kind ? 'T' : 'G'; }
}  // namespace

uint8_t ControlStore::rd(uint16_t a) const { return hal_.eeprom_read(a); }
void ControlStore::wr(uint16_t a, uint8_t v) { hal_.eeprom_write(a, v); }

uint16_t ControlStore::duration() const {
  const uint16_t rec = record(kTraj);
  return read16((uint16_t)(rec + 2 + (rd(rec) - 1) * (2 + 2 * (rd((uint16_t)(rec + 1)) & 3))));
}

void ControlStore::targets(uint16_t t, uint8_t* seg, int16_t out[ctl::kChannels]) const {
  const uint16_t rec = record(kTraj);
  const uint8_t n = rd(rec), cols = rd((uint16_t)(rec + 1)) & 3, pb = (uint8_t)(2 + 2 * cols);
  uint16_t p = (uint16_t)(rec + 2 + *seg * pb);
  while (*seg + 2 < n && t >= read16((uint16_t)(p + pb))) {
    ++*seg;
    p = (uint16_t)(p + pb);
  }
  const uint16_t t0 = read16(p);
  const int32_t span = (int32_t)(read16((uint16_t)(p + pb)) - t0);
  int32_t dt = (int32_t)(t - t0);
  if (dt > span) dt = span;
  for (uint8_t i = 0; i < ctl::kChannels; ++i) {
    const uint16_t y = (uint16_t)(p + 2 + (cols == 1 ? 0 : 2 * i));
    const int16_t y0 = (int16_t)read16(y);
    out[i] = (int16_t)(y0 + ((int32_t)(int16_t)read16((uint16_t)(y + pb)) - y0) * dt / span);
  }
}

uint16_t ControlStore::read16(uint16_t a) const { return (uint16_t)(rd(a) | (rd((uint16_t)(a + 1)) << 8)); }

uint8_t ControlStore::length(uint8_t kind, uint16_t rec) const {
  if (kind == kGains) return ctl::kGainsBytes + 2;
  const uint16_t n = (uint16_t)(2 + rd(rec) * (2 + 2 * (rd((uint16_t)(rec + 1)) & 3)) + 2);
  return n > kTrajMaxRecord ? 0 : (uint8_t)n;
}

bool ControlStore::crc_ok(uint16_t rec, uint8_t len) const {
  if (len < 4) return false;
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < len - 2; ++i) crc = proto::crc16_update(crc, rd((uint16_t)(rec + i)));
  return crc == read16((uint16_t)(rec + len - 2));
}

bool ControlStore::structure_ok(uint16_t rec) const {
  const uint8_t n = rd(rec), cols = rd((uint16_t)(rec + 1)) & 0x7F;
  if (n < 2 || (cols != 1 && cols != 3)) return false;
  uint16_t prev = 0;
  for (uint8_t i = 0; i < n; ++i) {
    const uint16_t p = (uint16_t)(rec + 2 + i * (2 + 2 * cols));
    const uint16_t t = read16(p);
    // Times from 0, increasing by 1..32767 ticks: (y1 - y0) * (t - t0) then fits an int32.
    if (i == 0 ? t != 0 : (uint16_t)(t - prev - 1) >= 32767) return false;
    prev = t;
    for (uint8_t c = 0; c < cols; ++c) {
      const int16_t y = (int16_t)read16((uint16_t)(p + 2 + 2 * c));
      if (y > ctl::kTargetLimit || y < -ctl::kTargetLimit) return false;
    }
  }
  return true;
}

void ControlStore::boot() {
  for (uint8_t kind = 0; kind < 2; ++kind) {
    slot_[kind] = kNoSlot;
    for (uint8_t s = 0; s < 2; ++s) {
      const uint16_t a = addr(kind, s);
      const uint8_t seq = rd((uint16_t)(a + 1));
      if (rd(a) == magic(kind) && crc_ok((uint16_t)(a + 2), length(kind, (uint16_t)(a + 2))) &&
          (slot_[kind] == kNoSlot || (uint8_t)(seq - seq_[kind]) < 128)) {
        slot_[kind] = s;
        seq_[kind] = seq;
      }
    }
  }
}

uint8_t ControlStore::write(uint8_t kind, uint8_t total, uint8_t offset, const uint8_t* data, uint8_t n,
                            int16_t* detail) {
  const uint8_t slot = slot_[kind] == 0 ? 1 : 0;
  const uint16_t a = addr(kind, slot);
  if (offset == 0) {
    total_ = 0;
    if (total > (kind ? kTrajMaxRecord : kGainsSlot - 2)) {
      *detail = (int16_t)(total - kTrajMaxRecord);
      return r::TOO_LARGE;
    }
    wr(a, 0xFF);  // never valid while torn
    wr((uint16_t)(a + 1), (uint8_t)(seq_[kind] + 1));
    total_ = total;
    next_ = 0;
  }
  *detail = next_;
  if (total_ == 0 || total != total_ || offset != next_) return r::BAD_STATE;
  if (n > (uint8_t)(total_ - offset)) {
    *detail = (int16_t)(offset + n - total_);
    return r::TOO_LARGE;
  }
  for (uint8_t i = 0; i < n; ++i) wr((uint16_t)(a + 2 + offset + i), data[i]);
  next_ = (uint8_t)(next_ + n);
  *detail = 0;
  if (next_ < total_) return r::OK;
  total_ = 0;
  const uint16_t rec = (uint16_t)(a + 2);
  if (length(kind, rec) != next_ || !crc_ok(rec, next_)) return r::BAD_MODEL;
  *detail = 1;
  if (kind == kTraj && !structure_ok(rec)) return r::BAD_MODEL;
  *detail = 0;
  wr(a, magic(kind));  // last: the copy counts from here on
  seq_[kind] = rd((uint16_t)(a + 1));
  slot_[kind] = slot;
  return r::OK;
}

}  // namespace dev
