#include "standalone_out.h"

namespace dev {

uint8_t format_fixed(char* out, int32_t v, uint8_t decimals) {
  char digits[10];
  uint8_t n = 0;
  // Work on the magnitude as unsigned: -2^31 has no positive int32.
  uint32_t mag = v < 0 ? (uint32_t)0 - (uint32_t)v : (uint32_t)v;
  do {
    digits[n++] = (char)('0' + mag % 10);
    mag /= 10;
  } while (mag != 0 || n <= decimals);  // at least one digit before the point
  uint8_t len = 0;
  if (v < 0) out[len++] = '-';
  while (n > 0) {
    if (n == decimals) out[len++] = '.';
    out[len++] = digits[--n];
  }
  return len;
}

uint8_t format_text(char* out, const char* text) {
  uint8_t n = 0;
  while (text[n]) {
    out[n] = text[n];
    ++n;
  }
  return n;
}

}  // namespace dev
