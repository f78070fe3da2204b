// What the command handler needs from the model store and the estimator. model_link.{h,cpp}
// implements it with est::Estimator and the EEPROM model store; host tests use fakes.
// Result values are proto::result codes; detail follows NAK.detail of the catalogue.
#pragma once
#include <stdint.h>

#include "ports.h"
#include "protocol_messages.h"

namespace dev {

class ModelPort {
 public:
  PORT_FN uint8_t begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) PORT_ABSTRACT;
  PORT_FN uint8_t chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail) PORT_ABSTRACT;
  PORT_FN uint8_t commit(int16_t* detail) PORT_ABSTRACT;  // OK: the estimator is loaded
  PORT_FN uint8_t erase() PORT_ABSTRACT;
  PORT_FN uint8_t read(uint16_t offset, uint8_t n, uint8_t* dst) PORT_ABSTRACT;
  PORT_FN void info(proto::ModelInfoReply* out) PORT_ABSTRACT;
  PORT_FN uint8_t status() PORT_ABSTRACT;    // 0 none, 1 valid, 2 invalid or incompatible
  PORT_FN uint16_t crc() PORT_ABSTRACT;      // of the stored blob, 0 when none
  PORT_FN bool flash_store() PORT_ABSTRACT;  // the flash model store is read (HELLO capability)
  PORT_FN bool estimator_loaded() PORT_ABSTRACT;
  PORT_FN void estimator_reset() PORT_ABSTRACT;
  PORT_FN uint8_t estimator_step(const int16_t dr_centi[3], int16_t estimate[3]) PORT_ABSTRACT;  // bit0 saturated
};

}  // namespace dev
