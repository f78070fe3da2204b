// The device configuration (CONFIG_GET/SET keys of protocol/messages.toml): held compactly
// in RAM, limits from proto::config::key_info, stored in EEPROM bytes 0..63 as two 32-byte
// slots (version, sequence, packed values, CRC). A save writes the older slot, so a reset
// mid-write leaves the previous configuration intact.
#pragma once
#include <stdint.h>

#include "hal.h"

namespace dev {

struct Config {
  uint8_t sample_rate_hz;
  uint8_t channel_mask;
  uint8_t r0_mode;
  uint8_t adc_pga;
  uint8_t adc_rate;
  uint8_t autostart;
  uint8_t pwm_pin;
  uint8_t line_mode;
  uint8_t schedule_enable;
  int16_t min_setpoint_dkpa;
  int16_t pwm_offset;
  uint16_t watchdog_ms;
  uint16_t boots;  // boots since the stored configuration was created
  int32_t r0_mohm[kChannels];
  int32_t pwm_scale_milli;

  void set_defaults();
  bool get(uint8_t key, int32_t* value) const;  // false: unknown key
  uint8_t set(uint8_t key, int32_t value);      // proto::result code
};

constexpr uint16_t kConfigSlotSize = 32;
constexpr uint16_t kConfigBase = 0;
constexpr uint8_t kConfigFormat = 1;

class ConfigStore {
 public:
  explicit ConfigStore(Hal& hal) : hal_(hal), seq_(0), slot_(0) {}
  // Newest valid slot into cfg; false (cfg at defaults) when neither slot is valid.
  bool load(Config* cfg);
  void save(const Config& cfg);  // writes the slot not holding the newest copy
  void erase();                  // invalidates both slots

 private:
  bool read_slot(uint8_t slot, Config* cfg, uint8_t* seq);
  Hal& hal_;
  uint8_t seq_;
  uint8_t slot_;  // slot holding the newest valid copy
};

}  // namespace dev
