#include "model_store.h"

#include <string.h>

#include "frame_codec.h"

namespace est {

namespace res = proto::result;
namespace L = layout;

void ModelStore::Reader::read(uint16_t offset, void* dst, uint8_t n) const {
  if (flash_)
    flash_->read_block(uint16_t(base_ + offset), static_cast<uint8_t*>(dst), n);
  else
    ee_->read_block(uint16_t(base_ + offset), static_cast<uint8_t*>(dst), n);
}

ModelStore::ModelStore(Eeprom& ee, Estimator& estimator, FlashRom* flash)
    : ModelStoreState(), ee_(ee), est_(estimator), flash_(flash) {
  static_assert(kNone == 0, "status_ starts zero");
  active_ = kNoSlot;
  for (uint8_t r = 0; r < 2; ++r) readers_[r].bind(&ee_, 0, kAreaBase);
}

uint16_t ModelStore::read16(uint16_t addr) {
  return uint16_t(ee_.read(addr) | uint16_t(ee_.read(uint16_t(addr + 1))) << 8);
}

void ModelStore::read_header(uint8_t slot, uint8_t* b) {
  if (slot < kFlashSlot0)
    ee_.read_block(header_addr(slot), b, L::kSlotHeaderLen);
  else
    flash_->read_block(uint16_t(flash_addr(slot) + L::kFlashBlobMax), b, L::kSlotHeaderLen);
}

bool ModelStore::read_slot(uint8_t slot, SlotHeader* h) {
  uint8_t b[L::kSlotHeaderLen];
  read_header(slot, b);
  if (b[L::kOffSlotMagic] != L::kSlotMagic) return false;
  if (proto::crc16(b, L::kOffSlotHeaderCrc) !=
      uint16_t(b[L::kOffSlotHeaderCrc] | uint16_t(b[L::kOffSlotHeaderCrc + 1]) << 8)) {
    return false;
  }
  h->seq = b[L::kOffSlotSeq];
  h->length = uint16_t(b[L::kOffSlotLength] | uint16_t(b[L::kOffSlotLength + 1]) << 8);
  h->crc = uint16_t(b[L::kOffSlotCrc] | uint16_t(b[L::kOffSlotCrc + 1]) << 8);
  return h->length >= blob::kHeaderLen + blob::kCrcLen &&
         h->length <= (slot < kFlashSlot0 ? kAreaLen : L::kFlashBlobMax);
}

bool ModelStore::load(uint8_t slot, uint16_t length, uint16_t crc) {
  // The estimator's own check (format, CRC of the body against the trailer, structure) is
  // the only one; the trailer must also be the CRC the slot header or MODEL_BEGIN announced.
  const uint8_t spare = status_ == kValid ? uint8_t(run_ ^ 1) : run_;
  Reader& r = readers_[spare];
  const bool flash = slot >= kFlashSlot0;
  r.bind(&ee_, flash ? flash_ : 0, flash ? flash_addr(slot) : blob_addr(slot, length));
  const uint16_t max_len = flash ? L::kFlashBlobMax : blob::kMaxLength;
  if (blob::stored_crc(r, length) != crc || !est_.load(r, length, max_len)) return false;
  active_ = slot;
  run_ = spare;
  length_ = length;
  crc_ = crc;
  status_ = kValid;
  return true;
}

void ModelStore::boot() {
  est_.unload();
  writing_ = false;
  length_ = crc_ = 0;
  status_ = kNone;
  active_ = kNoSlot;
  SlotHeader h[kAllSlots];
  bool present[kAllSlots];
  const uint8_t n_slots = flash_usable() ? kAllSlots : L::kSlots;
  for (uint8_t s = 0; s < n_slots; ++s) {
    uint8_t b[L::kSlotHeaderLen];
    read_header(s, b);
    if (b[L::kOffSlotMagic] == L::kSlotMagic) status_ = kInvalid;  // a header, maybe a bad one
    present[s] = read_slot(s, &h[s]);
  }
  // Latest first: seq counts commits modulo 256, so a later one is ahead by less than 128. A
  // slot that fails its checks is dropped and the next latest tried. (On equal seqs the lower
  // slot number wins: the EEPROM's before the flash store's.)
  for (;;) {
    uint8_t best = kNoSlot;
    for (uint8_t s = 0; s < n_slots; ++s) {
      if (present[s] && (best == kNoSlot || int8_t(h[s].seq - h[best].seq) > 0)) best = s;
    }
    if (best == kNoSlot) return;
    if (load(best, h[best].length, h[best].crc)) {
      seq_ = h[best].seq;
      return;
    }
    present[best] = false;
  }
}

uint8_t ModelStore::begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) {
  *detail = 0;
  if (length > room()) {
    *detail = int16_t(length - room());
    return res::TOO_LARGE;
  }
  if (format_version != blob::kFormatVersion || length < blob::kHeaderLen + blob::kCrcLen) {
    return res::BAD_MODEL;
  }
  // The EEPROM slot that is not running; its old contents (an older model) are given up here.
  target_ = active_ == 0 ? 1 : 0;
  ee_.write(header_addr(target_), 0xFF);
  writing_ = true;
  expect_len_ = length;
  expect_crc_ = crc;
  next_offset_ = 0;
  return res::OK;
}

uint8_t ModelStore::chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail) {
  *detail = 0;
  if (!writing_) return res::BAD_STATE;
  if (offset != next_offset_) {
    *detail = int16_t(next_offset_);
    return res::BAD_STATE;
  }
  if (uint32_t(offset) + n > expect_len_) {
    *detail = int16_t(uint32_t(offset) + n - expect_len_);
    return res::TOO_LARGE;
  }
  uint16_t at = uint16_t(blob_addr(target_, expect_len_) + offset);
  for (uint8_t i = 0; i < n; ++i) ee_.write(uint16_t(at + i), data[i]);
  next_offset_ = uint16_t(offset + n);
  return res::OK;
}

uint8_t ModelStore::commit(int16_t* detail) {
  *detail = 0;
  if (!writing_) return res::BAD_STATE;
  if (next_offset_ != expect_len_) {
    *detail = int16_t(next_offset_);
    return res::BAD_STATE;
  }
  writing_ = false;
  uint8_t running = active_;
  if (!load(target_, expect_len_, expect_crc_)) {
    // Wrong CRC (detail 0) or a blob the estimator refuses (detail 1); the running model stays.
    const Reader& r = readers_[status_ == kValid ? run_ ^ 1 : run_];  // the one load() checked
    *detail = blob::stored_crc(r, expect_len_) == expect_crc_ &&
              blob::crc(r, uint16_t(expect_len_ - blob::kCrcLen)) == expect_crc_;
    return res::BAD_MODEL;
  }
  // The estimator now runs the new blob; it is stored for good once its slot header is written.
  seq_ = uint8_t(running == kNoSlot ? 0 : seq_ + 1);
  uint16_t crc = expect_crc_;
  uint8_t b[L::kSlotHeaderLen];
  b[L::kOffSlotMagic] = L::kSlotMagic;
  b[L::kOffSlotSeq] = seq_;
  b[L::kOffSlotLength] = uint8_t(expect_len_ & 0xFF);
  b[L::kOffSlotLength + 1] = uint8_t(expect_len_ >> 8);
  b[L::kOffSlotCrc] = uint8_t(crc & 0xFF);
  b[L::kOffSlotCrc + 1] = uint8_t(crc >> 8);
  uint16_t hc = proto::crc16(b, L::kOffSlotHeaderCrc);
  b[L::kOffSlotHeaderCrc] = uint8_t(hc & 0xFF);
  b[L::kOffSlotHeaderCrc + 1] = uint8_t(hc >> 8);
  uint16_t at = header_addr(target_);
  for (uint8_t i = 1; i < L::kSlotHeaderLen; ++i) ee_.write(uint16_t(at + i), b[i]);
  ee_.write(at, L::kSlotMagic);  // from this byte on, the new model is the one that boots
  return res::OK;
}

uint8_t ModelStore::erase() {
  est_.unload();
  for (uint8_t s = 0; s < L::kSlots; ++s) ee_.write(header_addr(s), 0xFF);
  writing_ = false;
  status_ = kNone;
  active_ = kNoSlot;
  length_ = crc_ = 0;
  return res::OK;
}

uint8_t ModelStore::read(uint16_t offset, uint8_t n, uint8_t* dst) {
  if (status_ != kValid) return res::NO_MODEL;
  if (n == 0 || uint32_t(offset) + n > length_) return res::OUT_OF_RANGE;
  readers_[run_].read(offset, dst, n);
  return res::OK;
}

void ModelStore::info(proto::ModelInfoReply* out) {
  memset(out, 0, sizeof(*out));
  out->status = status_;
  out->slot = active_;
  if (status_ != kValid) return;
  out->seq = seq_;
  const blob::Header& h = est_.header();
  out->format_version = h.format_version;
  out->length = length_;
  out->crc = crc_;
  out->n_inputs = h.n_inputs;
  out->n_outputs = h.n_outputs;
  out->model_id = h.model_id;
  for (uint8_t j = 0; j < 3; ++j) out->out_scale[j] = h.out_scale[j];
}

}  // namespace est
