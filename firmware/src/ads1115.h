// ADS1115 16-bit ADC: single-shot conversions of AIN0..AIN3 against GND. Each read writes
// the config register (MUX for the channel, PGA, data rate, OS = start), waits the nominal
// conversion time, polls the OS bit until the conversion is done or the deadline passes,
// then reads the conversion register.
#pragma once
#include <stdint.h>

class Ads1115 {
 public:
  explicit Ads1115(uint8_t addr) : addr_(addr), pga_(1), rate_(7), present_(false) {}
  bool begin();                           // probe; false when the chip does not answer
  void configure(uint8_t pga_code, uint8_t rate_code);  // codes of the datasheet (0..5, 0..7)
  bool read(uint8_t channel, int16_t* counts);
  bool present() const { return present_; }
  uint32_t conversion_us() const;        // nominal time of one conversion

 private:
  uint8_t addr_;
  uint8_t pga_;
  uint8_t rate_;
  bool present_;
};
