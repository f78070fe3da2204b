// The EEPROM model store: MODEL_BEGIN / MODEL_CHUNK / MODEL_COMMIT / MODEL_ERASE / MODEL_READ
// over a byte-wide EEPROM, with an atomic commit (MODEL_FORMAT.md):
//
//   region (base 64, 960 bytes) = store header (8 bytes) + blob (at most 952 bytes)
//   store header: magic 'M' 'S', blob length u16, blob CRC u16, header CRC u16 (of bytes 0..5)
//
// BEGIN invalidates the header (magic first), CHUNKs write the blob contiguously, COMMIT
// checks length, CRC and structure (Estimator::load) and then writes the header, magic last.
// A reset at any moment therefore leaves the old model (before BEGIN's first write) or no
// model, never a broken one. A stored blob that fails its checks at boot keeps the estimator
// off with status 2 (invalid or incompatible).
#pragma once
#include <stdint.h>

#include "estimator.h"
#include "protocol_messages.h"

namespace est {

// The store's only view of the EEPROM. read_block() exists so that the estimator reads a
// whole section record in one call on the AVR (eeprom_read_block); the default loops.
class Eeprom {
 public:
  virtual uint8_t read(uint16_t addr) = 0;
  virtual void write(uint16_t addr, uint8_t value) = 0;  // may skip unchanged bytes
  virtual void read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
    for (uint8_t i = 0; i < n; ++i) dst[i] = read(uint16_t(addr + i));
  }
};

class ModelStore {
 public:
  static constexpr uint16_t kBase = 64, kRegion = 960, kHeaderLen = 8;
  static constexpr uint16_t kBlobBase = kBase + kHeaderLen;
  static constexpr uint8_t kMagic0 = 'M', kMagic1 = 'S';
  enum Status : uint8_t { kNone = 0, kValid = 1, kInvalid = 2 };

  ModelStore(Eeprom& ee, Estimator& estimator);
  // At power-up: check the stored model and load the estimator when it is valid.
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
  bool writing() const { return writing_; }
  const BlobReader& reader() const { return reader_; }

 private:
  class Reader : public BlobReader {
   public:
    explicit Reader(Eeprom& ee) : ee_(ee) {}
    void read(uint16_t offset, void* dst, uint8_t n) const override;

   private:
    Eeprom& ee_;
  };

  void invalidate();
  uint16_t read16(uint16_t addr);
  void write16(uint16_t addr, uint16_t v);

  Eeprom& ee_;
  Estimator& est_;
  Reader reader_;
  uint8_t status_;
  bool writing_;
  uint16_t length_, crc_;          // of the stored model
  uint16_t expect_len_, expect_crc_, next_offset_;  // of the write in progress
};

}  // namespace est
