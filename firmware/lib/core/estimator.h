// The on-device fixed-point Wiener-Hammerstein estimator (docs/design.md):
//   y_j = offset_j + H2_j( g_j( sum_i H1_ij( f_ij( u_i[k - delay_ij] - u_offset_ij ) ) ) )
// f, g piecewise-linear (int16 -> int16); H1, H2 cascades of second-order sections with int16
// inputs/outputs and int32 states; saturating arithmetic, no float, no heap. Coefficients stay
// in the blob and are read through a BlobReader each step (EEPROM on the Uno).
// Number formats: MODEL_FORMAT.md (this directory); bit-exact twin: porosense.quant.
#pragma once
#include <stdint.h>

#include "model_blob.h"

namespace est {

constexpr uint8_t kDelayLen = 16;  // per-input delay line, shared by every output

// The estimator's state, all zero when unloaded: value-initialised as one block (one clearing
// loop in flash instead of a store per field).
struct EstimatorState {
  const BlobReader* blob_;
  uint16_t length_;
  uint8_t n_in_, n_out_;
  blob::Header header_;
  uint8_t head_;
  uint8_t flags_;
  // Running positions during a step: blob offset, next cascade's input history and states.
  uint16_t off_;
  int16_t* xh_;
  int32_t* ys_;
  int16_t delay_[blob::kMaxInputs][kDelayLen];
  int16_t xhist_[blob::kMaxCascades][2];        // inputs k-1, k-2 of each cascade
  int32_t ystate_[blob::kMaxTotalSections][2];  // outputs k-1, k-2 of each section (Q13)
};

class Estimator : private EstimatorState {
 public:
  Estimator();
  // Validates format, CRC and limits; on success keeps `blob` (it must outlive the
  // estimator) and resets the state. False -> nothing changes (a running model keeps running).
  // max_length defaults to the EEPROM model region; larger only for RAM/flash blobs.
  bool load(const BlobReader& blob, uint16_t length, uint16_t max_length = blob::kMaxLength);
  void unload();
  void reset();  // zero all filter states and delay lines
  // One sample: inputs dR in 0.01 %, estimates in output LSB (out_scale units per LSB).
  // Returns flags, bit0: a stage saturated. Off: estimates are zero, flags 0.
  uint8_t step(const int16_t dr_centi[3], int16_t estimate[3]);
  bool loaded() const { return blob_ != 0; }
  uint8_t n_inputs() const { return n_in_; }
  uint8_t n_outputs() const { return n_out_; }
  uint16_t length() const { return length_; }
  const blob::Header& header() const { return header_; }

  static constexpr uint8_t kSaturated = 0x01;
  // Bytes of state RAM (delay lines, input histories, section states).
  static constexpr uint16_t kStateBytes =
      blob::kMaxInputs * kDelayLen * 2 + blob::kMaxCascades * 4 + blob::kMaxTotalSections * 8;

 private:
  int16_t pwl(uint8_t n, int16_t x);
  int32_t cascade(uint8_t n, int16_t x);
};

}  // namespace est
