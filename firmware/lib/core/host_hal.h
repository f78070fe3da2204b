// dev::Hal and est::Eeprom for the host library (host_api.cpp): the board's hardware as
// plain state that the host sets and reads. Models the chips, not the firmware: an ADS1115
// converting a pushed voltage with the configured gain, a BNO055 reporting pushed angles,
// a 1 KB EEPROM, a UART with byte queues. Host only (uses the C++ standard library).
#pragma once
#if !defined(__AVR__)
#include <stdint.h>

#include <vector>

#include "hal.h"
#include "model_store.h"

namespace host {

typedef void (*RefreshFn)(void* ctx, uint32_t conversion_us);

// The flash model store of the host board: a plain array the host programs as an upload would.
// (Not a base of HostHal: est::Eeprom has a read_block of the same signature.)
class HostFlash : public est::FlashRom {
 public:
  static constexpr uint16_t kBytes = est::layout::kFlashSlots * est::layout::kFlashSlotSize;
  HostFlash() {
    for (uint16_t i = 0; i < kBytes; ++i) mem[i] = 0xFF;
  }
  void read_block(uint16_t addr, uint8_t* dst, uint8_t n) override {
    for (uint8_t i = 0; i < n; ++i) dst[i] = uint16_t(addr + i) < kBytes ? mem[addr + i] : 0xFF;
  }
  uint8_t mem[kBytes];
};

class HostHal : public dev::Hal, public est::Eeprom {
 public:
  static constexpr uint16_t kEepromBytes = 1024;

  HostHal();
  // Power-on: RAM-side state (queues, pending conversion, chip configuration) is lost.
  void power_on(uint8_t reset_cause, uint64_t clock_offset_us);

  // ---- dev::Hal
  uint32_t micros() override { return (uint32_t)now_us_; }
  uint32_t millis() override { return (uint32_t)(now_us_ / 1000u); }
  void apply_outputs(const dev::Outputs& out) override { outputs_ = out; }
  bool adc_start(uint8_t ch) override;
  bool adc_finish(int16_t* counts) override;
  void adc_configure(uint8_t pga_code, uint8_t rate_code) override;
  bool imu_read(int16_t euler_16[3], uint8_t* sys_cal) override;
  bool adc_present() override { return adc_present_; }
  bool imu_present() override { return imu_present_; }
  int16_t serial_read() override;
  void serial_write(const uint8_t* data, uint8_t n) override;
  uint8_t serial_tx_free() override;
  uint8_t eeprom_read(uint16_t addr) override { return read(addr); }
  void eeprom_write(uint16_t addr, uint8_t value) override { write(addr, value); }
  void request_reset() override { reset_requested_ = true; }
  uint16_t free_stack() override { return kReportedFreeStack; }
  uint8_t reset_cause() override { return reset_cause_; }
  void analog_out(uint8_t pin, uint8_t duty) override {
    analog_pin_ = pin;
    analog_duty_ = duty;
  }

  // ---- est::Eeprom
  uint8_t read(uint16_t addr) override { return addr < kEepromBytes ? eeprom_[addr] : 0xFF; }
  void write(uint16_t addr, uint8_t value) override;

  // ---- host side
  void set_refresh(RefreshFn fn, void* ctx) {
    refresh_ = fn;
    refresh_ctx_ = ctx;
  }
  void set_present(bool adc, bool imu) {
    adc_present_ = adc;
    imu_present_ = imu;
  }
  void set_inputs(const double volts[3], const double euler_deg[3]);
  void set_tx_room(uint32_t room) { tx_room_ = room; }
  void fail_after_writes(int32_t n, uint16_t first_addr) {
    fail_after_ = n;
    fail_from_ = first_addr;
  }
  void set_time(uint64_t t_us) {
    if (t_us > now_us_) now_us_ = t_us;
  }
  uint64_t now_us() const { return now_us_; }
  uint32_t feed(const uint8_t* data, uint32_t n);
  bool rx_pending() const { return rx_pos_ < rx_.size(); }
  uint32_t take(uint8_t* dst, uint32_t max);

  uint8_t* eeprom() { return eeprom_; }
  uint8_t* flash_store() { return flash_.mem; }
  HostFlash* flash() { return &flash_; }
  const dev::Outputs& outputs() const { return outputs_; }
  bool power_lost() const { return power_lost_; }
  bool reset_requested() const { return reset_requested_; }
  uint8_t analog_pin() const { return analog_pin_; }
  uint8_t analog_duty() const { return analog_duty_; }
  uint32_t eeprom_writes() const { return eeprom_writes_; }

 private:
  // STATUS.free_ram: the host has no AVR stack to measure; a plausible constant.
  static constexpr uint16_t kReportedFreeStack = 512;

  uint8_t eeprom_[kEepromBytes];
  HostFlash flash_;  // survives power cycles like the EEPROM
  uint64_t now_us_;
  uint8_t reset_cause_;
  bool adc_present_, imu_present_;
  uint8_t pga_, rate_;
  int pending_ch_;  // channel of the conversion started, -1 when none
  double volts_[3];
  double euler_deg_[3];
  uint8_t fresh_;  // bit ch: volts_[ch] not yet converted
  RefreshFn refresh_;
  void* refresh_ctx_;
  std::vector<uint8_t> rx_, tx_;
  size_t rx_pos_;
  uint32_t tx_room_;
  int32_t fail_after_;
  uint16_t fail_from_;
  bool power_lost_, reset_requested_;
  dev::Outputs outputs_;
  uint8_t analog_pin_, analog_duty_;
  uint32_t eeprom_writes_;
};

}  // namespace host
#endif
