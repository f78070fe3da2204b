// ADS1115 16-bit ADC: single-shot conversions of AIN0..AIN3 against GND. start() writes the
// config register (MUX for the channel, PGA, data rate, OS = start); finish() waits out the
// nominal conversion time (running the idle hook), polls the OS bit until the conversion is
// done or its deadline (twice the nominal time + 2 ms) passes, then reads the result. Work
// placed between start() and finish() overlaps the conversion.
#pragma once
#include <stdint.h>

class Ads1115 {
 public:
  explicit Ads1115(uint8_t addr) : addr_(addr), pga_(1), rate_(7), present_(false), t_start_(0) {}
  bool begin();                                         // probe; false when the chip does not answer
  void configure(uint8_t pga_code, uint8_t rate_code);  // codes of the datasheet (0..5, 0..7)
  bool start(uint8_t channel);
  bool finish(int16_t* counts);
  bool read(uint8_t channel, int16_t* counts) { return start(channel) && finish(counts); }
  bool present() const { return present_; }
  uint32_t conversion_us() const;  // nominal time of one conversion

 private:
  bool fail();
  uint8_t addr_;
  uint8_t pga_;
  uint8_t rate_;
  bool present_;
  uint32_t t_start_;
};
