// dev::ModelPort backed by the model store (est::ModelStore: EEPROM slots, and flash slots when
// a FlashRom is given) and the fixed-point
// estimator (est::Estimator): the command handler's model commands are delegated here.
#pragma once
#include <stdint.h>

#include "estimator.h"
#include "model_port.h"
#include "model_store.h"

namespace dev {

class ModelLink final : public ModelPort {
 public:
  explicit ModelLink(est::Eeprom& eeprom, est::FlashRom* flash = 0) : store_(eeprom, estimator_, flash) {}
  // Load and check the stored model (a bad one stays off); image_end: the firmware image's end
  // in flash, bytes (ModelStore::set_image_end).
  void boot(uint16_t image_end = 0) {
    store_.set_image_end(image_end);
    store_.boot();
  }

  uint8_t begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) PORT_OVERRIDE {
    return store_.begin(length, crc, format_version, detail);
  }
  uint8_t chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail) PORT_OVERRIDE {
    return store_.chunk(offset, data, n, detail);
  }
  uint8_t commit(int16_t* detail) PORT_OVERRIDE { return store_.commit(detail); }
  uint8_t erase() PORT_OVERRIDE { return store_.erase(); }
  uint8_t read(uint16_t offset, uint8_t n, uint8_t* dst) PORT_OVERRIDE { return store_.read(offset, n, dst); }
  void info(proto::ModelInfoReply* out) PORT_OVERRIDE { store_.info(out); }
  uint8_t status() PORT_OVERRIDE { return store_.status(); }
  uint16_t crc() PORT_OVERRIDE { return store_.crc(); }
  bool flash_store() PORT_OVERRIDE { return store_.flash_usable(); }
  bool estimator_loaded() PORT_OVERRIDE { return estimator_.loaded(); }
  void estimator_reset() PORT_OVERRIDE { estimator_.reset(); }
  uint8_t estimator_step(const int16_t dr_centi[3], int16_t estimate[3]) PORT_OVERRIDE {
    return estimator_.step(dr_centi, estimate);
  }

 private:
  est::Estimator estimator_;  // constructed before the store, which keeps a reference
  est::ModelStore store_;
};

}  // namespace dev
