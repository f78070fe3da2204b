// The EEPROM model store: MODEL_BEGIN / MODEL_CHUNK / MODEL_COMMIT / MODEL_ERASE / MODEL_READ
// over a byte-wide EEPROM, with two slots so that a new model never replaces the running one
// before it is whole (layout: model_layout.h from protocol/model_layout.toml; MODEL_FORMAT.md):
//
//   region (base 64, 960 bytes) = slot header 0 | slot header 1 | blob area (944 bytes)
//   slot 0's blob starts at the bottom of the area, slot 1's ends at its top
//   slot header: magic 'M', seq u8, blob length u16, blob CRC u16, header CRC u16 (of bytes 0..5)
//
// BEGIN picks the slot that is not running and needs room for the new blob beside the running
// one (else TOO_LARGE, detail = the excess); it invalidates only that slot. CHUNKs write the
// blob there while the running model keeps estimating. COMMIT checks length, CRC and structure
// and only then writes the slot header (magic last) with the next seq and switches the
// estimator over. A reset at any moment leaves the old model (or, after the magic byte, the new
// one) running; a refused blob leaves the old one running.
//
// The flash store adds two read-only slots (2 and 3) at the top of the application flash,
// written at upload time (avrdude -D): blob from the slot's first byte, the same slot header in
// its last 8 bytes (layout::kFlash*). At boot the valid slot with the latest seq across both
// stores runs; one that fails its checks is skipped for the next latest.
#pragma once
#include <stdint.h>

#include "estimator.h"
#include "model_layout.h"
#include "ports.h"
#include "protocol_messages.h"

namespace est {

// The store's only view of the EEPROM. read_block() exists so that the estimator reads a
// whole section record in one call on the AVR (eeprom_read_block); the default loops.
class Eeprom {
 public:
  PORT_FN uint8_t read(uint16_t addr) PORT_ABSTRACT;
  PORT_FN void write(uint16_t addr, uint8_t value) PORT_ABSTRACT;  // may skip unchanged bytes
#if PORTS_STATIC
  void read_block(uint16_t addr, uint8_t* dst, uint8_t n);
#else
  virtual void read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
    for (uint8_t i = 0; i < n; ++i) dst[i] = read(uint16_t(addr + i));
  }
#endif
};

// The store's only view of the flash model slots: read-only, addresses from layout::kFlashBase
// (memcpy_P on the AVR, a plain array on the host).
class FlashRom {
 public:
  PORT_FN void read_block(uint16_t addr, uint8_t* dst, uint8_t n) PORT_ABSTRACT;
};

// ModelStore's plain state, value-initialised as one block (one clearing loop in flash).
struct ModelStoreState {
  uint8_t run_;
  uint8_t status_, active_, seq_;  // seq_: of the running model
  bool writing_;
  uint16_t length_, crc_;  // of the running model
  uint8_t target_;         // slot of the write in progress
  uint16_t expect_len_, expect_crc_, next_offset_;
  uint16_t image_end_;  // end of the firmware image in flash (0: none, a host build)
};

class ModelStore : private ModelStoreState {
 public:
  static constexpr uint16_t kBase = layout::kStoreBase, kRegion = layout::kStoreRegion;
  static constexpr uint16_t kHeaderLen = layout::kSlotHeaderLen;
  static constexpr uint16_t kAreaBase = layout::kAreaBase, kAreaLen = layout::kAreaLen;
  static constexpr uint8_t kNoSlot = 0xFF;
  // Slots 0, 1: EEPROM; kFlashSlot0.. : flash.
  static constexpr uint8_t kFlashSlot0 = layout::kSlots, kAllSlots = layout::kSlots + layout::kFlashSlots;
  enum Status : uint8_t { kNone = 0, kValid = 1, kInvalid = 2 };

  ModelStore(Eeprom& ee, Estimator& estimator, FlashRom* flash = 0);
  // The firmware image's end in flash (bytes), before boot(): an image that reaches the flash
  // store's base (a build over its budget) would be read as model slots, so the store is then
  // left alone.
  void set_image_end(uint16_t end) { image_end_ = end; }
  // True when the flash store's slots are read: a FlashRom is attached and the image ends
  // below the store.
  bool flash_usable() const { return flash_ && image_end_ <= layout::kFlashBase; }
  // At power-up: check both slots and load the estimator from the newest valid one.
  void boot();
  // Commands; each returns a proto::result code and sets *detail as NAK.detail expects
  // (TOO_LARGE: excess bytes; BAD_STATE: the expected offset; otherwise 0).
  uint8_t begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail);
  uint8_t chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail);
  uint8_t commit(int16_t* detail);
  uint8_t erase();
  uint8_t read(uint16_t offset, uint8_t n, uint8_t* dst);
  void info(proto::ModelInfoReply* out);

  uint8_t status() const { return status_; }
  uint16_t crc() const { return status_ == kValid ? crc_ : 0; }
  uint16_t length() const { return status_ == kValid ? length_ : 0; }
  uint8_t active_slot() const { return active_; }
  uint8_t seq() const { return seq_; }
  bool writing() const { return writing_; }
  // Bytes a new blob may have in the EEPROM beside the running model (all of it when the
  // running model is in flash).
  uint16_t room() const { return status_ == kValid && active_ < kFlashSlot0 ? uint16_t(kAreaLen - length_) : kAreaLen; }
  const BlobReader& reader() const { return readers_[run_]; }

 private:
  class Reader : public BlobReader {
   public:
    Reader() : ee_(0), flash_(0), base_(kAreaBase) {}
    void bind(Eeprom* ee, FlashRom* flash, uint16_t base) { ee_ = ee, flash_ = flash, base_ = base; }
    void read(uint16_t offset, void* dst, uint8_t n) const override;

   private:
    Eeprom* ee_;
    FlashRom* flash_;  // set: read from the flash store instead
    uint16_t base_;
  };
  struct SlotHeader {
    uint8_t seq;
    uint16_t length, crc;
  };

  static uint16_t header_addr(uint8_t slot) { return uint16_t(kBase + slot * kHeaderLen); }
  static uint16_t blob_addr(uint8_t slot, uint16_t length) {
    return slot == 0 ? kAreaBase : uint16_t(kAreaBase + kAreaLen - length);
  }
  static uint16_t flash_addr(uint8_t slot) { return uint16_t((slot - kFlashSlot0) * layout::kFlashSlotSize); }
  void read_header(uint8_t slot, uint8_t* b);
  bool read_slot(uint8_t slot, SlotHeader* h);  // header magic and CRC only
  // Checks the blob of `slot` and, when whole and valid, runs it; false leaves all as it was.
  bool load(uint8_t slot, uint16_t length, uint16_t crc);
  uint16_t read16(uint16_t addr);

  Eeprom& ee_;
  Estimator& est_;
  FlashRom* flash_;  // 0: no flash store
  // Two readers: the running model's (run_) and one for the slot being checked, so that a
  // refused blob never disturbs the running one.
  Reader readers_[2];
};

}  // namespace est
