// The host library: dev::Device with dev::ModelLink over host::HostHal, behind host_api.h.
// The AVR build compiles this file to nothing.
#if !defined(__AVR__)
#include "host_api.h"

#include <math.h>
#include <string.h>

#include "device.h"
#include "host_hal.h"
#include "model_link.h"
#include "rate_divider.h"

static_assert(PS_FLASH_STORE_BASE == est::layout::kFlashBase && PS_FLASH_STORE_BYTES == host::HostFlash::kBytes,
              "host_api.h's flash store constants follow model_layout.h");

namespace host {

namespace {
// ADS1115 full scale per PGA code (V) and data rate per rate code (samples/s).
const double kFullScaleV[6] = {6.144, 4.096, 2.048, 1.024, 0.512, 0.256};
const uint16_t kDataRateSps[8] = {8, 16, 32, 64, 128, 250, 475, 860};

int16_t saturate16(double v) {
  if (!(v == v)) return 0;
  if (v >= 32767.0) return 32767;
  if (v <= -32768.0) return -32768;
  return (int16_t)nearbyint(v);
}
}  // namespace

HostHal::HostHal()
    : now_us_(0),
      reset_cause_(PS_RESET_POWER_ON),
      adc_present_(true),
      imu_present_(true),
      pga_(0),
      rate_(0),
      pending_ch_(-1),
      fresh_(0),
      refresh_(0),
      refresh_ctx_(0),
      rx_pos_(0),
      tx_room_(255),
      fail_after_(-1),
      fail_from_(0),
      power_lost_(false),
      reset_requested_(false),
      outputs_(),
      analog_pin_(0),
      analog_duty_(0),
      eeprom_writes_(0) {
  memset(eeprom_, 0xFF, sizeof eeprom_);
  for (int i = 0; i < 3; ++i) volts_[i] = euler_deg_[i] = 0.0;
}

void HostHal::power_on(uint8_t reset_cause, uint64_t clock_offset_us) {
  now_us_ = clock_offset_us;
  reset_cause_ = reset_cause;
  pga_ = rate_ = 0;
  pending_ch_ = -1;
  rx_.clear();
  rx_pos_ = 0;
  tx_.clear();
  power_lost_ = reset_requested_ = false;
  outputs_ = dev::Outputs();
  analog_pin_ = analog_duty_ = 0;
  eeprom_writes_ = 0;
}

bool HostHal::adc_start(uint8_t ch) {
  pending_ch_ = -1;
  if (!adc_present_ || ch >= 3) return false;
  if (!(fresh_ & (1u << ch)) && refresh_) refresh_(refresh_ctx_, 1000000u / kDataRateSps[rate_ < 8 ? rate_ : 7]);
  fresh_ &= (uint8_t) ~(1u << ch);
  pending_ch_ = ch;
  return true;
}

bool HostHal::adc_finish(int16_t* counts) {
  if (!adc_present_ || pending_ch_ < 0) return false;
  const double lsb = kFullScaleV[pga_ < 6 ? pga_ : 5] / 32768.0;
  *counts = saturate16(volts_[pending_ch_] / lsb);
  pending_ch_ = -1;
  return true;
}

void HostHal::adc_configure(uint8_t pga_code, uint8_t rate_code) {
  pga_ = pga_code;
  rate_ = rate_code;
}

bool HostHal::imu_read(int16_t euler_16[3], uint8_t* sys_cal) {
  if (!imu_present_) return false;
  for (int i = 0; i < 3; ++i) euler_16[i] = saturate16(euler_deg_[i] * 16.0);
  *sys_cal = 3;
  return true;
}

int16_t HostHal::serial_read() {
  if (power_lost_ || rx_pos_ >= rx_.size()) return -1;
  return rx_[rx_pos_++];
}

void HostHal::serial_write(const uint8_t* data, uint8_t n) {
  if (power_lost_) return;
  tx_.insert(tx_.end(), data, data + n);
}

uint8_t HostHal::serial_tx_free() {
  const uint32_t room = tx_room_ > tx_.size() ? tx_room_ - (uint32_t)tx_.size() : 0;
  return (uint8_t)(room > 255 ? 255 : room);
}

void HostHal::write(uint16_t addr, uint8_t value) {
  if (power_lost_ || addr >= kEepromBytes || eeprom_[addr] == value) return;
  if (fail_after_ >= 0 && addr >= fail_from_) {
    if (fail_after_ == 0) {
      power_lost_ = true;
      fail_after_ = -1;
      return;
    }
    --fail_after_;
  }
  eeprom_[addr] = value;
  ++eeprom_writes_;
}

void HostHal::set_inputs(const double volts[3], const double euler_deg[3]) {
  for (int i = 0; i < 3; ++i) {
    volts_[i] = volts[i];
    euler_deg_[i] = euler_deg[i];
  }
  fresh_ = 0x07;
}

uint32_t HostHal::feed(const uint8_t* data, uint32_t n) {
  if (rx_pos_ == rx_.size()) {
    rx_.clear();
    rx_pos_ = 0;
  }
  rx_.insert(rx_.end(), data, data + n);
  return n;
}

uint32_t HostHal::take(uint8_t* dst, uint32_t max) {
  const uint32_t n = (uint32_t)(tx_.size() < max ? tx_.size() : max);
  if (n == 0) return 0;
  memcpy(dst, tx_.data(), n);
  tx_.erase(tx_.begin(), tx_.begin() + n);
  return n;
}

// One powered board: the firmware objects are rebuilt at each boot (RAM lost), the
// HostHal (EEPROM, presence, callbacks) outlives them.
struct Board {
  explicit Board(HostHal& hal) : model(hal, hal.flash()), device(hal, model), clock_rate(0), last_ms(0) {}
  dev::ModelLink model;
  dev::Device device;
  dev::RateDivider divider;
  uint16_t clock_rate;
  uint64_t last_ms;  // the latest whole device millisecond the 1 kHz tick has run for
};

}  // namespace host

struct ps_core {
  host::HostHal hal;
  host::Board* board;
};

namespace {

void sync_clock(ps_core* c) {
  host::Board& b = *c->board;
  if (b.device.rate_hz() != b.clock_rate) {
    // Like sample_clock::set_rate: the divider restarts; the 1 kHz tick runs on from now.
    b.clock_rate = b.device.rate_hz();
    b.divider.set_rate(b.clock_rate);
    const uint64_t now_ms = c->hal.now_us() / 1000u;
    if (now_ms > b.last_ms) b.last_ms = now_ms;
  }
}

bool halted(ps_core* c) { return !c->board || c->hal.power_lost() || c->hal.reset_requested(); }

}  // namespace

extern "C" {

ps_core* ps_create(void) {
  ps_core* c = new ps_core;
  c->board = 0;
  return c;
}

void ps_destroy(ps_core* c) {
  if (!c) return;
  delete c->board;
  delete c;
}

void ps_boot(ps_core* c, uint8_t reset_cause, uint64_t clock_offset_us) {
  delete c->board;
  c->hal.power_on(reset_cause, clock_offset_us);
  c->board = new host::Board(c->hal);
  c->board->last_ms = clock_offset_us / 1000u;
  // The order of the sketch's setup(): outputs safe, model store checked, device begun.
  c->board->model.boot();
  c->board->device.begin();
  sync_clock(c);
}

uint8_t* ps_eeprom(ps_core* c) { return c->hal.eeprom(); }
uint8_t* ps_flash_store(ps_core* c) { return c->hal.flash_store(); }
void ps_set_refresh(ps_core* c, ps_refresh_fn fn, void* ctx) { c->hal.set_refresh(fn, ctx); }
void ps_set_present(ps_core* c, int adc, int imu) { c->hal.set_present(adc != 0, imu != 0); }
void ps_set_inputs(ps_core* c, const double volts[3], const double euler_deg[3]) {
  c->hal.set_inputs(volts, euler_deg);
}
void ps_set_tx_room(ps_core* c, uint32_t room) { c->hal.set_tx_room(room); }
void ps_fail_after_writes(ps_core* c, int32_t n, uint16_t first_addr) { c->hal.fail_after_writes(n, first_addr); }
void ps_set_time(ps_core* c, uint64_t t_us) { c->hal.set_time(t_us); }
uint32_t ps_feed(ps_core* c, const uint8_t* data, uint32_t n) { return c->hal.feed(data, n); }
uint32_t ps_take(ps_core* c, uint8_t* dst, uint32_t max) { return c->hal.take(dst, max); }

void ps_poll(ps_core* c) {
  if (halted(c)) return;
  // One command per pass of the sketch's loop(); the last pass runs the link watchdog.
  do {
    c->board->device.poll();
    if (halted(c)) return;
  } while (c->hal.rx_pending() || c->board->device.frame_pending());
  sync_clock(c);
}

int64_t ps_next_tick(ps_core* c) {
  if (halted(c) || c->board->clock_rate == 0) return -1;
  dev::RateDivider probe = c->board->divider;
  for (uint64_t ms = c->board->last_ms + 1; ms <= c->board->last_ms + dev::kTickHz; ++ms)
    if (probe.tick()) return (int64_t)(ms * 1000u);
  return -1;
}

uint32_t ps_run_to(ps_core* c, uint64_t t_us) {
  if (halted(c)) return 0;
  c->hal.set_time(t_us);
  host::Board& b = *c->board;
  const uint64_t now_ms = t_us / 1000u;
  uint32_t ticks = 0;
  uint64_t tick_ms = 0;
  if (b.clock_rate == 0) {
    b.last_ms = now_ms;
  } else {
    for (; b.last_ms < now_ms;) {
      ++b.last_ms;
      if (b.divider.tick()) {
        ++ticks;
        tick_ms = b.last_ms;
      }
    }
  }
  if (ticks) {
    b.device.on_sample_ticks((uint8_t)(ticks > 255 ? 255 : ticks), (uint32_t)(tick_ms * 1000u));
    sync_clock(c);
  }
  return ticks;
}

uint32_t ps_step(ps_core* c, uint64_t t_us, const double volts[3], const double euler_deg[3], uint32_t tx_room,
                 uint8_t* dst, uint32_t max, uint32_t* n_sent, ps_state* st) {
  c->hal.set_inputs(volts, euler_deg);
  c->hal.set_tx_room(tx_room);
  const uint32_t ticks = ps_run_to(c, t_us);
  ps_poll(c);
  *n_sent = c->hal.take(dst, max);
  ps_state_get(c, st);
  return ticks;
}

void ps_state_get(ps_core* c, ps_state* out) {
  memset(out, 0, sizeof *out);
  const dev::Outputs& o = c->hal.outputs();
  for (int i = 0; i < 3; ++i) out->setpoint_dkpa[i] = o.setpoint_dkpa[i];
  out->pump_mask = o.pump_mask;
  out->valve_mask = o.valve_mask;
  out->power_lost = c->hal.power_lost();
  out->reset_requested = c->hal.reset_requested();
  out->analog_pin = c->hal.analog_pin();
  out->analog_duty = c->hal.analog_duty();
  out->eeprom_writes = c->hal.eeprom_writes();
  if (c->board) {
    const dev::Device& d = c->board->device;
    out->streaming = d.streaming();
    out->rate_hz = d.rate_hz();
    out->flags = d.flags();
    out->rx_frames = d.counters().rx_frames;
    out->tx_frames = d.counters().tx_frames;
  }
}

}  // extern "C"
#endif  // !__AVR__
