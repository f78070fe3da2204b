// The model blob: the fixed-point estimator's coefficients as stored in EEPROM.
// Layout and number formats: MODEL_FORMAT.md (this directory). The Python twin
// is porosense.protocol.model_blob; both sides must agree byte for byte.
// Pure C++ (no Arduino header, no heap, no float in the hot path).
#pragma once
#include <stdint.h>

#include "model_layout.h"

namespace est {

// Where the estimator reads its coefficients: RAM on the host, EEPROM on the Uno.
class BlobReader {
 public:
  virtual void read(uint16_t offset, void* dst, uint8_t n) const = 0;
};

// A blob held in RAM (host tests, REPLAY checks, a blob in flash copied to RAM).
class RamBlobReader : public BlobReader {
 public:
  RamBlobReader(const uint8_t* data, uint16_t size) : data_(data), size_(size) {}
  void read(uint16_t offset, void* dst, uint8_t n) const override;

 private:
  const uint8_t* data_;
  uint16_t size_;
};

namespace blob {

// Layout constants are generated from protocol/model_layout.toml (model_layout.h).
constexpr uint8_t kMagic0 = layout::kBlobMagic0;  // 'P'
constexpr uint8_t kMagic1 = layout::kBlobMagic1;  // 'W'
constexpr uint8_t kFormatVersion = layout::kFormatVersion;
constexpr uint8_t kHeaderLen = layout::kHeaderLen;
constexpr uint8_t kCrcLen = layout::kCrcLen;
constexpr uint16_t kMaxLength = layout::kMaxBlobLength;  // one model in an empty store

// Header offsets.
constexpr uint8_t kOffMagic = layout::kOffMagic, kOffVersion = layout::kOffFormatVersion,
                  kOffInputs = layout::kOffNInputs, kOffOutputs = layout::kOffNOutputs,
                  kOffReserved = layout::kOffReserved, kOffLength = layout::kOffLength,
                  kOffModelId = layout::kOffModelId, kOffOutScale = layout::kOffOutScale, kOffTsUs = layout::kOffTsUs,
                  kOffInputLsb = layout::kOffInputLsb;

// Limits of the structure (docs/design.md): 3 inputs, 3 outputs, 16 breakpoints, 5 sections
// (10 poles) per linear block, delays of at most 15 samples.
constexpr uint8_t kMaxInputs = layout::kMaxInputs, kMaxOutputs = layout::kMaxOutputs,
                  kMaxBranches = layout::kMaxBranches, kMaxBreakpoints = layout::kMaxBreakpoints,
                  kMaxSections = layout::kMaxSections, kMaxDelay = layout::kMaxDelay;
constexpr uint8_t kMaxCascades = kMaxOutputs * (kMaxBranches + 1);  // 12
constexpr uint8_t kMaxTotalSections = kMaxCascades * kMaxSections;  // 60

// Output record flags.
constexpr uint8_t kOutHasG = layout::kOutHasG, kOutHasH2 = layout::kOutHasH2;
// Branch record flags.
constexpr uint8_t kBranchHasF = layout::kBranchHasF;
// Section flags byte: bit0 32-bit numerator, bit1 delta form, bits 2-4 m1 + 2, bits 5-6 m2 + 1.
constexpr uint8_t kSecWide = layout::kSecWide, kSecDelta = layout::kSecDelta;
constexpr uint8_t kSecFixedLen = layout::kSecRecLen;  // flags, sb, n1, n2
constexpr uint8_t kSecLen16 = kSecFixedLen + 6 + 4;   // 14
constexpr uint8_t kSecLen32 = kSecFixedLen + 12 + 4;  // 20
constexpr uint8_t kOutputRecLen = layout::kOutputRecLen, kBranchRecLen = layout::kBranchRecLen;

// Section states are int32 in Q13 of the section's int16 output and saturate here.
constexpr int32_t kStateMax = (int32_t(1) << 28) - 1;
constexpr int32_t kStateMin = -(int32_t(1) << 28);
constexpr uint8_t kStateFrac = 13;

// Bytes of a table from its count byte: n breakpoints (bits 0-6), compact when bit 7 is set.
inline uint16_t pwl_len(uint8_t count) {
  const uint8_t n = count & uint8_t(~layout::kTableCompact);
  return (count & layout::kTableCompact) ? uint16_t(1 + 4 * n) : uint16_t(1 + 4 * n + 3 * (n - 1));
}

struct Header {
  uint8_t format_version;
  uint8_t n_inputs;
  uint8_t n_outputs;
  uint16_t length;
  uint32_t model_id;
  float out_scale[3];
};

// CRC-16/MCRF4XX over bytes [0, n) of the blob (the protocol's CRC).
uint16_t crc(const BlobReader& r, uint16_t n);

// The CRC stored in the last two bytes of a blob of `length` bytes.
uint16_t stored_crc(const BlobReader& r, uint16_t length);

// True when the section's denominator 1 + a1 z^-1 + a2 z^-2 (fields as stored: flags, n1, n2,
// k1, k2; MODEL_FORMAT.md) has both poles strictly inside the unit circle: A(1) > 0, A(-1) > 0
// and a2 < 1, decided exactly in integer arithmetic. A pole on or outside the circle would let
// the estimate grow without bound (or ring forever) on the board.
bool section_stable(uint8_t flags, uint8_t n1, uint8_t n2, int16_t k1, int16_t k2);

// Parses the header without checking the body; false when magic, version or counts are bad,
// the length field disagrees with `length`, the sample period is 0 or too long, or the input
// scaling is not the device's (dR in 0.01 % per LSB).
bool read_header(const BlobReader& r, uint16_t length, Header* out, uint16_t max_length = kMaxLength);

// Full check: header, CRC and a walk of every record against the limits and the number
// formats' bounds (so the step can never overflow). Counts cascades and sections.
// max_length: the EEPROM limit by default; larger only for blobs held in RAM or flash.
bool validate(const BlobReader& r, uint16_t length, uint16_t max_length = kMaxLength, uint8_t* n_cascades = 0,
              uint8_t* n_sections = 0);

}  // namespace blob
}  // namespace est
