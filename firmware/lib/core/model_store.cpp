#include "model_store.h"

#include <string.h>

#include "frame_codec.h"

namespace est {

namespace res = proto::result;

void ModelStore::Reader::read(uint16_t offset, void* dst, uint8_t n) const {
  ee_.read_block(uint16_t(kBlobBase + offset), static_cast<uint8_t*>(dst), n);
}

ModelStore::ModelStore(Eeprom& ee, Estimator& estimator)
    : ee_(ee), est_(estimator), reader_(ee), status_(kNone), writing_(false), length_(0), crc_(0),
      expect_len_(0), expect_crc_(0), next_offset_(0) {}

uint16_t ModelStore::read16(uint16_t addr) {
  return uint16_t(ee_.read(addr) | uint16_t(ee_.read(uint16_t(addr + 1))) << 8);
}

void ModelStore::write16(uint16_t addr, uint16_t v) {
  ee_.write(addr, uint8_t(v & 0xFF));
  ee_.write(uint16_t(addr + 1), uint8_t(v >> 8));
}

void ModelStore::boot() {
  est_.unload();
  writing_ = false;
  length_ = crc_ = 0;
  status_ = kNone;
  if (ee_.read(kBase) != kMagic0 || ee_.read(kBase + 1) != kMagic1) return;
  uint8_t h[6];
  for (uint8_t i = 0; i < 6; ++i) h[i] = ee_.read(uint16_t(kBase + i));
  uint16_t len = uint16_t(h[2] | uint16_t(h[3]) << 8);
  uint16_t crc = uint16_t(h[4] | uint16_t(h[5]) << 8);
  status_ = kInvalid;
  if (proto::crc16(h, 6) != read16(kBase + 6)) return;
  if (len > blob::kMaxLength || len < blob::kHeaderLen + blob::kCrcLen) return;
  if (blob::crc(reader_, uint16_t(len - blob::kCrcLen)) != crc) return;
  if (!est_.load(reader_, len)) return;  // incompatible format or structure
  length_ = len;
  crc_ = crc;
  status_ = kValid;
}

void ModelStore::invalidate() {
  // One byte is enough to invalidate; the second keeps a torn first write harmless.
  ee_.write(kBase, 0xFF);
  ee_.write(kBase + 1, 0xFF);
}

uint8_t ModelStore::begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) {
  *detail = 0;
  if (length > blob::kMaxLength) {
    *detail = int16_t(length - blob::kMaxLength);
    return res::TOO_LARGE;
  }
  if (format_version != blob::kFormatVersion || length < blob::kHeaderLen + blob::kCrcLen) {
    return res::BAD_MODEL;
  }
  est_.unload();
  invalidate();
  status_ = kNone;
  length_ = crc_ = 0;
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
  for (uint8_t i = 0; i < n; ++i) ee_.write(uint16_t(kBlobBase + offset + i), data[i]);
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
  uint16_t body = uint16_t(expect_len_ - blob::kCrcLen);
  uint16_t crc = blob::crc(reader_, body);
  if (crc != expect_crc_ || read16(uint16_t(kBlobBase + body)) != crc) {
    status_ = kNone;
    return res::BAD_MODEL;
  }
  if (!est_.load(reader_, expect_len_)) {
    *detail = 1;  // CRC fine, structure or limits not
    status_ = kNone;
    return res::BAD_MODEL;
  }
  uint8_t h[6] = {kMagic0, kMagic1, uint8_t(expect_len_ & 0xFF), uint8_t(expect_len_ >> 8),
                  uint8_t(crc & 0xFF), uint8_t(crc >> 8)};
  for (uint8_t i = 2; i < 6; ++i) ee_.write(uint16_t(kBase + i), h[i]);
  write16(kBase + 6, proto::crc16(h, 6));
  ee_.write(kBase + 1, kMagic1);
  ee_.write(kBase, kMagic0);  // the model becomes valid with this byte
  length_ = expect_len_;
  crc_ = crc;
  status_ = kValid;
  return res::OK;
}

uint8_t ModelStore::erase() {
  est_.unload();
  invalidate();
  writing_ = false;
  status_ = kNone;
  length_ = crc_ = 0;
  return res::OK;
}

uint8_t ModelStore::read(uint16_t offset, uint8_t n, uint8_t* dst) {
  if (status_ != kValid) return res::NO_MODEL;
  if (n == 0 || uint32_t(offset) + n > length_) return res::OUT_OF_RANGE;
  reader_.read(offset, dst, n);
  return res::OK;
}

void ModelStore::info(proto::ModelInfoReply* out) {
  memset(out, 0, sizeof(*out));
  out->status = status_;
  if (status_ != kValid) return;
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
