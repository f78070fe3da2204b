// EEPROM home of the strain controller's stored gains and trajectory, carved from the top of
// the model area (docs/model-store.md):
//
//   856..907   gains:      two 26-byte slots  'G' seq record(24: ctl::Gains, CRC)
//   908..1023  trajectory: two 58-byte slots  'T' seq record(<= 56)
//
// A record ends with the CRC-16/MCRF4XX of its other bytes. A write goes to the slot not
// holding the newest valid copy: magic invalidated first, seq and record, magic last, so a
// reset at any moment keeps the previous copy. At boot the valid slot with the later seq wins.
// Trajectory record (TRAJECTORY_CHUNK): n_points u8 (>= 2), flags u8 (bits 0-1 columns 1 or
// 3, bit 7 repeat), per point t u16 (10 ms; 0 first, then increasing by 1..32767) and a
// target i16 per column (LSB, |target| <= 30000), then the CRC. Its structure is checked when
// it is written; at boot only its CRC.
#pragma once
#include <stdint.h>

#include "control.h"
#include "hal.h"

namespace dev {

constexpr uint16_t kCtlBase = 856;
constexpr uint8_t kGainsSlot = 2 + ctl::kGainsBytes + 2;   // 26
constexpr uint16_t kTrajBase = kCtlBase + 2 * kGainsSlot;  // 908
constexpr uint8_t kTrajSlot = 58;
constexpr uint8_t kTrajMaxRecord = kTrajSlot - 2;  // 56: 13 points of 1 column, 6 of 3
constexpr uint8_t kTrajRepeat = 0x80;
constexpr uint8_t kNoSlot = 0xFF;

class ControlStore {
 public:
  enum Kind : uint8_t { kGains = 0, kTraj = 1 };

  explicit ControlStore(Hal& hal) : hal_(hal), next_(0), total_(0) {
    slot_[0] = slot_[1] = kNoSlot;
    seq_[0] = seq_[1] = 0;
  }
  void boot();  // finds the newest valid copy of each kind
  bool has(uint8_t kind) const { return slot_[kind] != kNoSlot; }
  // EEPROM address of the newest valid record of `kind` (when has(kind)).
  uint16_t record(uint8_t kind) const { return (uint16_t)(addr(kind, slot_[kind]) + 2); }
  // Bytes of a record at `offset` of `total`; offset 0 starts a new copy. The byte that
  // completes it checks it (trajectory: structure too) and makes it the newest. Returns a
  // proto::result code and *detail as TRAJECTORY_CHUNK's NAK.detail.
  uint8_t write(uint8_t kind, uint8_t total, uint8_t offset, const uint8_t* data, uint8_t n, int16_t* detail);

  uint8_t columns() const { return (uint8_t)(rd((uint16_t)(record(kTraj) + 1)) & 3); }
  bool repeat() const { return rd((uint16_t)(record(kTraj) + 1)) & kTrajRepeat; }
  uint16_t duration() const;  // time of the last point, 10 ms ticks
  // Targets of channels 0..2 at `t` ticks (<= duration()) into the stored trajectory,
  // interpolated linearly; *seg caches the segment (0 from the start; t never goes back).
  // Segments span 1..32767 ticks and targets +-30000, so (y1 - y0) * (t - t0) fits an int32.
  void targets(uint16_t t, uint8_t* seg, int16_t out[ctl::kChannels]) const;

 private:
  static uint16_t addr(uint8_t kind, uint8_t slot) {
    return kind ? (uint16_t)(kTrajBase + slot * kTrajSlot) : (uint16_t)(kCtlBase + slot * kGainsSlot);
  }
  uint8_t rd(uint16_t a) const;
  void wr(uint16_t a, uint8_t v);
  uint16_t read16(uint16_t a) const;
  // Length of the record at `rec` per its kind (trajectory: from its header, 0 if too long).
  uint8_t length(uint8_t kind, uint16_t rec) const;
  bool crc_ok(uint16_t rec, uint8_t len) const;  // trailing CRC of a record
  bool structure_ok(uint16_t rec) const;         // trajectory times and targets

  Hal& hal_;
  uint8_t slot_[2], seq_[2];
  uint8_t next_, total_;  // write in progress: next offset, record length (0: none)
};

}  // namespace dev
