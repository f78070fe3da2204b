// EEPROM home of the strain controller's stored gains and trajectory, carved from the top of
// the model area (docs/model-store.md):
//
//   856..907   gains: two 26-byte slots  'G' seq ctl::Gains(22) crc16
//   908..1023  trajectory: two 58-byte slots  'T' seq record(<= 56 bytes)
//
// Gains: CRC-16/MCRF4XX over seq and values; trajectory: the record's own trailing CRC
// (its structure is checked once, when it is written). A write goes to the slot not holding the
// newest valid copy, magic invalidated first and written last, so a reset at any moment keeps
// the previous copy. Trajectory record (TRAJECTORY_CHUNK): n_points u8, flags u8 (bits 0-1
// columns 1 or 3, bit 7 repeat), per point t u16 (10 ms, from 0, strictly increasing) and a
// target i16 per column (LSB, |target| <= 30000), then the CRC of the bytes before it.
#pragma once
#include <stdint.h>

#include "control.h"
#include "hal.h"

namespace dev {

constexpr uint16_t kCtlBase = 856;
constexpr uint16_t kGainsSlot = 2 + ctl::kGainsBytes + 2;
constexpr uint16_t kTrajBase = kCtlBase + 2 * kGainsSlot;  // 908
constexpr uint16_t kTrajSlot = 58;
constexpr uint8_t kTrajMaxRecord = kTrajSlot - 2;          // 56: 13 1-column or 6 3-column points
constexpr uint8_t kTrajRepeat = 0x80;
constexpr uint8_t kNoSlot = 0xFF;

class ControlStore {
 public:
  explicit ControlStore(Hal& hal)
      : hal_(hal), gains_slot_(kNoSlot), gains_seq_(0), traj_slot_(kNoSlot), traj_seq_(0), next_(0), total_(0) {}
  // At power-up: finds the newest valid copies; gains stay all zero when none is stored.
  void boot(ctl::Gains* gains);
  bool gains_stored() const { return gains_slot_ != kNoSlot; }
  void save_gains(const ctl::Gains& g);

  // TRAJECTORY_CHUNK; proto::result code, *detail as NAK.detail.
  uint8_t chunk(uint8_t total, uint8_t offset, const uint8_t* data, uint8_t n, int16_t* detail);
  bool has_trajectory() const { return traj_slot_ != kNoSlot; }
  uint8_t n_points() const { return rec(0); }
  uint8_t columns() const { return (uint8_t)(rec(1) & 3); }
  bool repeat() const { return rec(1) & kTrajRepeat; }
  // Point i: time (10 ms) and the target of column c.
  uint16_t point_t(uint8_t i) const { return rec16((uint8_t)(2 + i * point_bytes())); }
  int16_t point_y(uint8_t i, uint8_t c) const {
    return (int16_t)rec16((uint8_t)(2 + i * point_bytes() + 2 + 2 * c));
  }

 private:
  uint8_t point_bytes() const { return (uint8_t)(2 + 2 * columns()); }
  uint16_t traj_addr(uint8_t slot) const { return (uint16_t)(kTrajBase + slot * kTrajSlot); }
  uint8_t rec(uint8_t off) const { return hal_.eeprom_read((uint16_t)(traj_addr(traj_slot_) + 2 + off)); }
  uint16_t rec16(uint8_t off) const { return read16((uint16_t)(traj_addr(traj_slot_) + 2 + off)); }
  uint16_t read16(uint16_t addr) const;
  // The slot's CRC over [addr + 1, addr + 1 + n) against the u16 stored after it.
  bool crc_ok(uint16_t addr, uint8_t n) const;
  uint16_t crc_of(uint16_t addr, uint8_t n) const;
  // 0 when the slot's record (of `length` bytes; 0: as its header says) is whole: 1 its CRC
  // fails, 2 its structure (sizes, times from 0 increasing by 1..32767, targets within
  // +-30000; checked only when `structure`).
  uint8_t check_record(uint8_t slot, uint8_t length, bool structure) const;
  int16_t rec_at(uint16_t a) const { return (int16_t)read16(a); }
  void write(uint16_t addr, const uint8_t* src, uint8_t n);

  Hal& hal_;
  uint8_t gains_slot_, gains_seq_;
  uint8_t traj_slot_, traj_seq_;
  uint8_t next_, total_;  // trajectory write in progress: next offset, record length
};

}  // namespace dev
