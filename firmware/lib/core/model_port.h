// What the command handler needs from the model store and the estimator. model_link.{h,cpp}
// implements it with est::Estimator and the EEPROM model store; host tests use fakes.
// Result values are proto::result codes; detail follows NAK.detail of the catalogue.
#pragma once
#include <stdint.h>

#include "protocol_messages.h"

namespace dev {

class ModelPort {
 public:
  virtual uint8_t begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) = 0;
  virtual uint8_t chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail) = 0;
  virtual uint8_t commit(int16_t* detail) = 0;  // OK: the estimator is loaded
  virtual uint8_t erase() = 0;
  virtual uint8_t read(uint16_t offset, uint8_t n, uint8_t* dst) = 0;
  virtual void info(proto::ModelInfoReply* out) = 0;
  virtual uint8_t status() = 0;  // 0 none, 1 valid, 2 invalid or incompatible
  virtual uint16_t crc() = 0;    // of the stored blob, 0 when none
  virtual bool estimator_loaded() = 0;
  virtual void estimator_reset() = 0;
  virtual uint8_t estimator_step(const int16_t dr_centi[3], int16_t estimate[3]) = 0;  // bit0 saturated
};

}  // namespace dev
