// Host tests of the standalone outputs (firmware/lib/core/standalone_out.*): the integer
// formatter of the CSV line mode and the PWM duty of the analogue estimate output, against
// values computed here independently (printf with exact integers, 64-bit arithmetic).
#include "check.h"
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <string>

#include "standalone_out.h"

static std::string fixed(int32_t v, uint8_t decimals) {
  char buf[16];
  const uint8_t n = dev::format_fixed(buf, v, decimals);
  return std::string(buf, n);
}

static std::string reference(int64_t v, int decimals) {  // exact, via integers
  int64_t p = 1;
  for (int i = 0; i < decimals; ++i) p *= 10;
  const int64_t mag = v < 0 ? -v : v;
  char buf[40];
  if (decimals == 0)
    snprintf(buf, sizeof buf, "%s%lld", v < 0 ? "-" : "", (long long)mag);
  else
    snprintf(buf, sizeof buf, "%s%lld.%0*lld", v < 0 ? "-" : "", (long long)(mag / p), decimals, (long long)(mag % p));
  return buf;
}

static void test_format_fixed() {
  const int32_t values[] = {
      0, 1, -1, 9, -9, 10, 99, -100, 1234, -1234, 32767, -32768, 999999, 2147483647, -2147483647 - 1, 5, -5, 100000};
  int mismatches = 0;
  for (int32_t v : values)
    for (uint8_t d = 0; d <= 3; ++d) mismatches += fixed(v, d) != reference(v, d);
  // A sweep over every int16 (the dR column) with two decimals.
  for (int32_t v = -32768; v <= 32767; ++v) mismatches += fixed(v, 2) != reference(v, 2);
  CHECK(mismatches == 0);
  CHECK(fixed(-1234, 2) == "-12.34");
  CHECK(fixed(5, 3) == "0.005");
  CHECK(fixed(-5, 3) == "-0.005");
  printf("format_fixed: %d mismatches over 65,608 values\n", mismatches);
}

static void test_header_and_line() {
  char buf[dev::kHeaderMax + dev::kLineMax];
  uint8_t n = dev::format_header(buf, 0x07, 2);
  CHECK(std::string(buf, n) == "t_ms,dR0,dR1,dR2,est0,est1\r\n");
  n = dev::format_header(buf, 0x05, 0);
  CHECK(std::string(buf, n) == "t_ms,dR0,dR2\r\n");
  n = dev::format_header(buf, 0x07, 3);
  CHECK(n <= dev::kHeaderMax);
  const int16_t dr[3] = {-1234, 5, 32767};
  const int32_t est[3] = {1790, -140, -2000000000};
  n = dev::format_line(buf, 4294967295UL, 0x07, dr, 3, est);
  CHECK(std::string(buf, n) == "4294967295,-12.34,0.05,327.67,1.790,-0.140,-2000000.000\r\n");
  CHECK(n <= dev::kLineMax);
  const int16_t worst_dr[3] = {-32768, -32768, -32768};
  const int32_t worst_est[3] = {-2147483647 - 1, -2147483647 - 1, -2147483647 - 1};
  n = dev::format_line(buf, 4294967295UL, 0x07, worst_dr, 3, worst_est);
  printf("longest line: %u of %u characters\n", (unsigned)n, (unsigned)dev::kLineMax);
  CHECK(n <= dev::kLineMax);
}

static void test_pwm_duty() {
  int mismatches = 0, checked = 0;
  const int32_t scales[] = {0, 1, -1, 999, -999, 1000, -1000, 1001, 12345, -12345, 333333, 1000000, -1000000};
  const int16_t offsets[] = {0, 128, -255, 255, 17};
  for (int32_t s : scales)
    for (int16_t off : offsets)
      for (int32_t e = -32768; e <= 32767; e += 7) {
        int64_t q = (int64_t)e * s / 1000 + off;  // C++ division truncates toward zero
        if (q < 0) q = 0;
        if (q > 255) q = 255;
        mismatches += dev::analog_out_duty((int16_t)e, s, off) != (uint8_t)q;
        ++checked;
      }
  CHECK(mismatches == 0);
  CHECK(dev::analog_out_duty(100, 1500, 0) == 150);
  CHECK(dev::analog_out_duty(-3, 500, 10) == 9);  // -1.5 truncates to -1
  CHECK(dev::analog_out_pin_ok(0) && dev::analog_out_pin_ok(10));
  CHECK(!dev::analog_out_pin_ok(3) && !dev::analog_out_pin_ok(9) && !dev::analog_out_pin_ok(11));
  printf("analog_out_duty: %d mismatches in %d cases against 64-bit arithmetic\n", mismatches, checked);
}

int main() {
  test_format_fixed();
  test_header_and_line();
  test_pwm_duty();
  printf("test_standalone_out: %d checks, %d failures\n", g_checks, g_failures);
  return g_failures ? 1 : 0;
}
