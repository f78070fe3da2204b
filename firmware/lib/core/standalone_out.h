// Outputs for a board without a host: the analogue (PWM) copy of estimate 0 and the
// human-readable CSV line mode. Pure integer arithmetic, no printf (no float formatting).
#pragma once
#include <stdint.h>

namespace dev {

// D10 (Timer1 OC1B, 8-bit phase-correct PWM, 490 Hz) is the only PWM pin whose timer the
// firmware leaves free: Timer0 runs millis() and the D5/D6 regulators, Timer1 the D9
// regulator (D10 shares its 490 Hz setup), Timer2 is the sample clock (D3, D11).
constexpr uint8_t kAnalogOutPin = 10;

inline bool analog_out_pin_ok(uint8_t pin) { return pin == 0 || pin == kAnalogOutPin; }

// duty = clamp(estimate * scale_milli / 1000 + offset, 0, 255); the division truncates
// toward zero. Split as est * (s / 1000) + est * (s % 1000) / 1000 so no product leaves
// int32 (|est| <= 32768, |s| <= 1e6); both parts share the sign, so the split truncates
// exactly like the whole quotient.
inline uint8_t analog_out_duty(int16_t estimate, int32_t scale_milli, int16_t offset) {
  const int32_t whole = (int32_t)estimate * (scale_milli / 1000);
  const int32_t part = (int32_t)estimate * (scale_milli % 1000) / 1000;
  const int32_t d = whole + part + offset;
  return (uint8_t)(d < 0 ? 0 : d > 255 ? 255 : d);
}

// Writes v / 10^decimals in decimal ("-12.34" for v = -1234, decimals 2) at out; returns
// the number of characters (at most 12). No terminating zero.
uint8_t format_fixed(char* out, int32_t v, uint8_t decimals);

// Writes the CSV header naming the columns of format_line ("t_ms,dR0,dR1,dR2,est0,est1").
// Built from packed character constants, not string literals: on the AVR a literal would
// take RAM. Returns the length (at most 33, "\r\n" included).
constexpr uint8_t kHeaderMax = 4 + 3 * 4 + 3 * 5 + 2;
uint8_t format_header(char* out, uint8_t dr_mask, uint8_t n_est);

// One CSV line: t_ms, dR in % (2 decimals) of the channels in dr_mask, then n_est estimates
// in output units (3 decimals: est_milli = estimate * out_scale * 1000, rounded), "\r\n".
// out must hold kLineMax characters.
constexpr uint8_t kLineMax = 10 + 3 * 8 + 3 * 13 + 2;
// Free bytes of the Uno's empty serial transmit buffer (64-byte ring, one slot unused).
constexpr uint8_t kTxBufferFree = 63;
uint8_t format_line(char* out, uint32_t t_ms, uint8_t dr_mask, const int16_t dr_centi[3], uint8_t n_est,
                    const int32_t est_milli[3]);

}  // namespace dev
