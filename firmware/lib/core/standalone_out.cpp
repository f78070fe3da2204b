#include "standalone_out.h"

namespace dev {

namespace {
uint8_t format_magnitude(char* out, uint32_t mag, bool negative, uint8_t decimals) {
  char digits[10];
  uint8_t n = 0;
  do {
    digits[n++] = (char)('0' + mag % 10);
    mag /= 10;
  } while (mag != 0 || n <= decimals);  // at least one digit before the point
  uint8_t len = 0;
  if (negative) out[len++] = '-';
  while (n > 0) {
    if (n == decimals) out[len++] = '.';
    out[len++] = digits[--n];
  }
  return len;
}
}  // namespace

uint8_t format_fixed(char* out, int32_t v, uint8_t decimals) {
  // The magnitude as unsigned: -2^31 has no positive int32.
  return format_magnitude(out, v < 0 ? (uint32_t)0 - (uint32_t)v : (uint32_t)v, v < 0, decimals);
}

namespace {
// Four characters packed in a word: a constant in the code, not a string in RAM.
constexpr uint32_t chars4(char a, char b, char c, char d) {
  return (uint32_t)(uint8_t)a | (uint32_t)(uint8_t)b << 8 | (uint32_t)(uint8_t)c << 16 | (uint32_t)(uint8_t)d << 24;
}
// Appends the characters of w up to its first zero byte.
uint8_t put_chars(char* out, uint32_t w) {
  uint8_t n = 0;
  while (w & 0xFF) {
    out[n++] = (char)w;
    w >>= 8;
  }
  return n;
}
}  // namespace

uint8_t format_header(char* out, uint8_t dr_mask, uint8_t n_est) {
  uint8_t n = put_chars(out, chars4('t', '_', 'm', 's'));
  for (uint8_t ch = 0; ch < 3; ++ch)
    if (dr_mask & (1u << ch)) n = (uint8_t)(n + put_chars(out + n, chars4(',', 'd', 'R', (char)('0' + ch))));
  for (uint8_t j = 0; j < n_est && j < 3; ++j) {
    n = (uint8_t)(n + put_chars(out + n, chars4(',', 'e', 's', 't')));
    out[n++] = (char)('0' + j);
  }
  return (uint8_t)(n + put_chars(out + n, chars4('\r', '\n', 0, 0)));
}

uint8_t format_line(char* out, uint32_t t_ms, uint8_t dr_mask, const int16_t dr_centi[3], uint8_t n_est,
                    const int32_t est_milli[3]) {
  uint8_t n = 0;
  n = format_magnitude(out, t_ms, false, 0);
  for (uint8_t ch = 0; ch < 3; ++ch) {
    if (!(dr_mask & (1u << ch))) continue;
    out[n++] = ',';
    n = (uint8_t)(n + format_fixed(out + n, dr_centi[ch], 2));
  }
  for (uint8_t j = 0; j < n_est && j < 3; ++j) {
    out[n++] = ',';
    n = (uint8_t)(n + format_fixed(out + n, est_milli[j], 3));
  }
  return (uint8_t)(n + put_chars(out + n, chars4('\r', '\n', 0, 0)));
}

}  // namespace dev
