// The core's ports on the Uno (lib/core/ports.h): each forwards to the one class that
// implements it here, so the core's calls become direct calls (inlined under LTO).
#include "avr_eeprom.h"
#include "avr_flash.h"
#include "board.h"
#include "model_link.h"

#if PORTS_STATIC
namespace dev {
namespace {
Board& board(Hal* h) { return *static_cast<Board*>(h); }
}  // namespace

uint32_t Hal::micros() { return board(this).micros(); }
uint32_t Hal::millis() { return board(this).millis(); }
void Hal::apply_outputs(const Outputs& out) { board(this).apply_outputs(out); }
bool Hal::adc_start(uint8_t ch) { return board(this).adc_start(ch); }
bool Hal::adc_finish(int16_t* counts) { return board(this).adc_finish(counts); }
void Hal::adc_configure(uint8_t pga_code, uint8_t rate_code) { board(this).adc_configure(pga_code, rate_code); }
bool Hal::imu_read(int16_t euler_16[3], uint8_t* sys_cal) { return board(this).imu_read(euler_16, sys_cal); }
bool Hal::adc_present() { return board(this).adc_present(); }
bool Hal::imu_present() { return board(this).imu_present(); }
int16_t Hal::serial_read() { return board(this).serial_read(); }
void Hal::serial_write(const uint8_t* data, uint8_t n) { board(this).serial_write(data, n); }
uint8_t Hal::serial_tx_free() { return board(this).serial_tx_free(); }
uint8_t Hal::eeprom_read(uint16_t addr) { return board(this).eeprom_read(addr); }
void Hal::eeprom_write(uint16_t addr, uint8_t value) { board(this).eeprom_write(addr, value); }
void Hal::request_reset() { board(this).request_reset(); }
uint16_t Hal::free_stack() { return board(this).free_stack(); }
uint8_t Hal::reset_cause() { return board(this).reset_cause(); }
void Hal::analog_out(uint8_t pin, uint8_t duty) { board(this).analog_out(pin, duty); }

namespace {
ModelLink& link(ModelPort* p) { return *static_cast<ModelLink*>(p); }
}  // namespace

uint8_t ModelPort::begin(uint16_t length, uint16_t crc, uint8_t format_version, int16_t* detail) {
  return link(this).begin(length, crc, format_version, detail);
}
uint8_t ModelPort::chunk(uint16_t offset, const uint8_t* data, uint8_t n, int16_t* detail) {
  return link(this).chunk(offset, data, n, detail);
}
uint8_t ModelPort::commit(int16_t* detail) { return link(this).commit(detail); }
uint8_t ModelPort::erase() { return link(this).erase(); }
uint8_t ModelPort::read(uint16_t offset, uint8_t n, uint8_t* dst) { return link(this).read(offset, n, dst); }
void ModelPort::info(proto::ModelInfoReply* out) { link(this).info(out); }
uint8_t ModelPort::status() { return link(this).status(); }
uint16_t ModelPort::crc() { return link(this).crc(); }
bool ModelPort::flash_store() { return link(this).flash_store(); }
bool ModelPort::estimator_loaded() { return link(this).estimator_loaded(); }
void ModelPort::estimator_reset() { link(this).estimator_reset(); }
uint8_t ModelPort::estimator_step(const int16_t dr_centi[3], int16_t estimate[3]) {
  return link(this).estimator_step(dr_centi, estimate);
}
}  // namespace dev

namespace est {
uint8_t Eeprom::read(uint16_t addr) { return static_cast<AvrEeprom*>(this)->read(addr); }
void Eeprom::write(uint16_t addr, uint8_t value) { static_cast<AvrEeprom*>(this)->write(addr, value); }
void Eeprom::read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
  static_cast<AvrEeprom*>(this)->read_block(addr, dst, n);
}
void FlashRom::read_block(uint16_t addr, uint8_t* dst, uint8_t n) {
  static_cast<AvrFlash*>(this)->read_block(addr, dst, n);
}
}  // namespace est
#endif
