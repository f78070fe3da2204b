// The device core as a host shared library with a plain C interface: the emulator
// (porosense.emulator) runs the firmware's own dev::Device, model store and estimator through
// it. Never part of the AVR build (host_api.cpp compiles to nothing there).
//
// The host pushes what the hardware would present (sensor inputs, received bytes, the clock)
// and collects what the firmware produced (bytes to send, outputs, PWM duty). One callback
// lets the host refresh the sensor inputs when the firmware starts an ADC conversion that
// no pushed value covers (R0 calibration averages several conversions).
//
// Times are device time in microseconds since power-on as 64-bit values; the firmware sees
// them through micros()/millis() with the AVR's 32-bit wrap. The 1 kHz sample-clock tick
// falls on every whole device millisecond, divided to the stream rate by dev::RateDivider.
#pragma once
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

// Exported from the shared library even when it is built with -fvisibility=hidden.
#if defined(__GNUC__)
#define PS_API __attribute__((visibility("default")))
#else
#define PS_API
#endif

typedef struct ps_core ps_core;

// Called at an ADC conversion whose channel has no fresh input; conversion_us is the
// converter's conversion time at its configured data rate. The host may call
// ps_set_inputs() from inside it.
typedef void (*ps_refresh_fn)(void* ctx, uint32_t conversion_us);

// What the firmware drives, read after each call.
typedef struct {
  int16_t setpoint_dkpa[3];
  uint8_t pump_mask;
  uint8_t valve_mask;
  uint8_t streaming;
  uint8_t power_lost;       // an injected power loss struck during the last call
  uint8_t reset_requested;  // RESET was executed: the host reboots the core
  uint8_t analog_pin;       // pin of the latest analog_out(), 0 when never driven
  uint8_t analog_duty;
  uint16_t rate_hz;
  uint16_t flags;  // Device::flags()
  uint32_t rx_frames;
  uint32_t tx_frames;
  uint32_t eeprom_writes;  // bytes written to the EEPROM since power-on (all regions)
} ps_state;

#define PS_EEPROM_BYTES 1024
#define PS_RESET_POWER_ON 0x01
#define PS_RESET_EXTERNAL 0x02
#define PS_RESET_WATCHDOG 0x08

// A powered-off board with an erased (0xFF) EEPROM; ps_boot() powers it on.
PS_API ps_core* ps_create(void);
PS_API void ps_destroy(ps_core* c);
// Power-on or reset at device time 0 + clock_offset_us: RAM state is lost, the EEPROM kept;
// model store checked, configuration loaded, R0 calibrated (through the refresh callback).
PS_API void ps_boot(ps_core* c, uint8_t reset_cause, uint64_t clock_offset_us);
PS_API uint8_t* ps_eeprom(ps_core* c);  // PS_EEPROM_BYTES, readable and writable by the host
// The flash model store (PS_FLASH_STORE_BYTES from flash address PS_FLASH_STORE_BASE), erased
// (0xFF) at creation: the host programs pages into it as an upload would, then ps_boot().
#define PS_FLASH_STORE_BASE 30208
#define PS_FLASH_STORE_BYTES 2048
PS_API uint8_t* ps_flash_store(ps_core* c);

PS_API void ps_set_refresh(ps_core* c, ps_refresh_fn fn, void* ctx);
// Sensor presence (unplugged chips fail their transfers); survives reboots.
PS_API void ps_set_present(ps_core* c, int adc, int imu);
// Divider voltages of the three ADC inputs (V) and BNO055 Euler angles (heading, roll,
// pitch, degrees); marks all three ADC channels fresh.
PS_API void ps_set_inputs(ps_core* c, const double volts[3], const double euler_deg[3]);
// Free bytes of the transmit path besides what the core holds (telemetry that does not fit
// is dropped by the firmware); capped at 255 like the firmware's uint8_t view.
PS_API void ps_set_tx_room(ps_core* c, uint32_t room);
// After this many more EEPROM byte writes at addresses >= first_addr the power fails
// (negative: never). Writes after the failure are lost, bytes sent after it too.
PS_API void ps_fail_after_writes(ps_core* c, int32_t n, uint16_t first_addr);

// Device time since power-on (us); never goes back. Runs no firmware code.
PS_API void ps_set_time(ps_core* c, uint64_t t_us);
// Queue received bytes (the UART receive path); returns how many were taken.
PS_API uint32_t ps_feed(ps_core* c, const uint8_t* data, uint32_t n);
// The main loop: execute every queued command, run the host-link watchdog, follow the
// stream rate. Stops early after RESET or a power loss.
PS_API void ps_poll(ps_core* c);
// Device time (us since power-on) of the next sample tick, -1 when not streaming.
PS_API int64_t ps_next_tick(ps_core* c);
// Run the 1 kHz tick up to t_us (the clock moves there unless it is already later); when
// sample ticks fell due, take one sample for them (Device::on_sample_ticks, n > 1 counts overruns). Returns the ticks.
PS_API uint32_t ps_run_to(ps_core* c, uint64_t t_us);
// One pass of the host's sample loop in one call: present the inputs and the transmit room,
// run the clock to t_us (ps_run_to), run the main loop (ps_poll), then take at most max
// bytes sent (*n_sent) and the state. Returns the sample ticks taken.
PS_API uint32_t ps_step(ps_core* c, uint64_t t_us, const double volts[3], const double euler_deg[3], uint32_t tx_room,
                        uint8_t* dst, uint32_t max, uint32_t* n_sent, ps_state* st);
// Bytes the firmware wrote to the UART since the last call (at most max).
PS_API uint32_t ps_take(ps_core* c, uint8_t* dst, uint32_t max);
PS_API void ps_state_get(ps_core* c, ps_state* out);

#ifdef __cplusplus
}
#endif
