#include "estimator.h"

#include <string.h>

#define ALWAYS_INLINE static inline __attribute__((always_inline))

namespace est {
namespace {

using blob::kStateMax;
using blob::kStateMin;

// Little-endian fields of the blob (memcpy on little-endian targets: no shift loops on the AVR).
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
ALWAYS_INLINE int16_t le16(const uint8_t* p) {
  int16_t v;
  memcpy(&v, p, 2);
  return v;
}
ALWAYS_INLINE int32_t le32(const uint8_t* p) {
  int32_t v;
  memcpy(&v, p, 4);
  return v;
}
#else
ALWAYS_INLINE int16_t le16(const uint8_t* p) { return int16_t(uint16_t(p[0]) | uint16_t(p[1]) << 8); }
ALWAYS_INLINE int32_t le32(const uint8_t* p) {
  return int32_t(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
}
#endif

// ---------------------------------------------------------------------------------------------
// Arithmetic. The portable definitions below are the reference (identical to
// porosense.quant.fixed; the host tests run them). On the AVR the sections run in the
// assembly cascade (est_avr_cascade, below) with the hardware multiplier, and the few
// primitives the tables and the output stage need have inline-assembly versions: gcc 5.4
// would otherwise call libgcc for 32- and 64-bit products and shift bit by bit.
// tests/quant/test_avr_bitexact.py runs the AVR build in simavr against the Python reference.

// floor(v / 2^s), 0 <= s <= 31.
ALWAYS_INLINE int32_t asr_portable(int32_t v, uint8_t s) { return v >> s; }
// acc + a * b (callers bound the sum to int32).
ALWAYS_INLINE int32_t mac_portable(int32_t acc, int16_t a, int16_t b) { return acc + int32_t(a) * b; }
// floor(b * x / 2^16) for a 32-bit coefficient b.
ALWAYS_INLINE int32_t mul_wide_portable(int32_t b, int16_t x) { return int32_t((int64_t(b) * x) >> 16); }
// round(p * k / 2^n), ties up, 16 <= n <= 47, |p| <= 2^30 (the result fits an int32).
ALWAYS_INLINE int32_t mul_round_portable(int32_t p, int16_t k, uint8_t n) {
  return int32_t(((int64_t(p) * k >> (n - 1)) + 1) >> 1);
}
// s * |d| for a 16-bit magnitude d (|result| < 2^31).
ALWAYS_INLINE int32_t mul_su_portable(int16_t s, uint16_t d) { return int32_t(s) * int32_t(d); }
// floor(y / 2^13) of a state |y| <= 2^28.
ALWAYS_INLINE int16_t q13_portable(int32_t y) { return int16_t(y >> 13); }

#if defined(__AVR__)

// Shared (not inlined): one copy of the shift code for the tables and the output stage; byte
// moves for 16 and 8, then at most 7 single-bit steps.
__attribute__((noinline)) int32_t asr(int32_t v, uint8_t s) {
  asm("sbrs %[s], 4"
      "\n\t"
      "rjmp 1f"
      "\n\t"
      "movw %A[v], %C[v]"
      "\n\t"
      "clr %C[v]"
      "\n\t"
      "sbrc %B[v], 7"
      "\n\t"
      "com %C[v]"
      "\n\t"
      "mov %D[v], %C[v]"
      "\n"
      "1:"
      "\n\t"
      "sbrs %[s], 3"
      "\n\t"
      "rjmp 2f"
      "\n\t"
      "mov %A[v], %B[v]"
      "\n\t"
      "mov %B[v], %C[v]"
      "\n\t"
      "mov %C[v], %D[v]"
      "\n\t"
      "lsl %D[v]"
      "\n\t"
      "sbc %D[v], %D[v]"
      "\n"
      "2:"
      "\n\t"
      "andi %[s], 7"
      "\n\t"
      "breq 4f"
      "\n"
      "3:"
      "\n\t"
      "asr %D[v]"
      "\n\t"
      "ror %C[v]"
      "\n\t"
      "ror %B[v]"
      "\n\t"
      "ror %A[v]"
      "\n\t"
      "dec %[s]"
      "\n\t"
      "brne 3b"
      "\n"
      "4:"
      : [v] "+r"(v), [s] "+d"(s));
  return v;
}

// Signed s times unsigned d.
ALWAYS_INLINE int32_t mul_su(int16_t s, uint16_t d) {
  int32_t r;
  uint8_t z;
  asm("clr %[z]"
      "\n\t"
      "mulsu %B[s], %B[d]"
      "\n\t"
      "movw %C[r], r0"
      "\n\t"
      "mul %A[s], %A[d]"
      "\n\t"
      "movw %A[r], r0"
      "\n\t"
      "mulsu %B[s], %A[d]"
      "\n\t"
      "sbc %D[r], %[z]"
      "\n\t"
      "add %B[r], r0"
      "\n\t"
      "adc %C[r], r1"
      "\n\t"
      "adc %D[r], %[z]"
      "\n\t"
      "mul %B[d], %A[s]"
      "\n\t"
      "add %B[r], r0"
      "\n\t"
      "adc %C[r], r1"
      "\n\t"
      "adc %D[r], %[z]"
      "\n\t"
      "clr __zero_reg__"
      : [r] "=&r"(r), [z] "=&r"(z)
      : [s] "a"(s), [d] "a"(d));
  return r;
}

// floor(y / 2^13): bytes 1..3 shifted left by 3, the top two bytes kept.
ALWAYS_INLINE int16_t q13(int32_t y) {
  int16_t r;
  uint8_t t;
  asm("mov %[t], %B[y]"
      "\n\t"
      "mov %A[r], %C[y]"
      "\n\t"
      "mov %B[r], %D[y]"
      "\n\t"
      "lsl %[t]"
      "\n\t"
      "rol %A[r]"
      "\n\t"
      "rol %B[r]"
      "\n\t"
      "lsl %[t]"
      "\n\t"
      "rol %A[r]"
      "\n\t"
      "rol %B[r]"
      "\n\t"
      "lsl %[t]"
      "\n\t"
      "rol %A[r]"
      "\n\t"
      "rol %B[r]"
      : [r] "=&r"(r), [t] "=&r"(t)
      : [y] "r"(y));
  return r;
}

#else

ALWAYS_INLINE int32_t asr(int32_t v, uint8_t s) { return asr_portable(v, s); }
ALWAYS_INLINE int32_t mul_su(int16_t s, uint16_t d) { return mul_su_portable(s, d); }
ALWAYS_INLINE int16_t q13(int32_t y) { return q13_portable(y); }

#endif

// round(v / 2^s), ties up: floor(v / 2^(s-1)) + 1, halved (no overflow of v + 2^(s-1)).
ALWAYS_INLINE int32_t round_shift(int32_t v, uint8_t s) {
  if (s == 0) return v;
  return (asr(v, uint8_t(s - 1)) + 1) >> 1;
}

ALWAYS_INLINE int16_t sat16(int32_t v, uint8_t* flags) {
  if (v > 32767) {
    *flags |= Estimator::kSaturated;
    return 32767;
  }
  if (v < -32768) {
    *flags |= Estimator::kSaturated;
    return -32768;
  }
  return int16_t(v);
}

#if !defined(__AVR__)
// Clamp of a state to [-2^28, 2^28 - 1]: in range exactly when bits 28..31 agree, i.e. when
// the top byte plus 0x10 is below 0x20 (one byte test instead of two 32-bit compares).
ALWAYS_INLINE int32_t clamp_state(int32_t v, uint8_t* flags) {
  uint8_t top = uint8_t(uint32_t(v) >> 24);
  if (uint8_t(top + 0x10) & 0xE0) {
    *flags |= Estimator::kSaturated;
    return (top & 0x80) ? kStateMin : kStateMax;
  }
  return v;
}

// One second-order section (record `rec`, MODEL_FORMAT.md). x: inputs at k, k-1, k-2 on entry,
// this section's outputs at k, k-1, k-2 on return (the next section's inputs: the cascade
// shares them instead of storing them twice). ys: states y[k-1], y[k-2] in Q13, updated.
// Returns y[k]. The portable definition of a section; on the AVR the cascade runs the same
// steps in assembly (est_avr_cascade below).
ALWAYS_INLINE int32_t run_section(const uint8_t* rec, int16_t x[3], int32_t ys[2], uint8_t* flags) {
  const uint8_t fl = rec[0];
  const uint8_t* c = rec + blob::kSecFixedLen;
  // Numerator in Q13 of the output: exact int32 for 16-bit b, floored partial products for
  // 32-bit b. Every term is bounded by validate() (|W| <= 2^29, |base| <= 3 * 2^28,
  // |P1| <= 2^28 + 1, |P2| <= 2^27 + 1), so the int32 sums cannot overflow.
  int32_t w = 0;
  if (fl & blob::kSecWide) {
    for (uint8_t i = 0; i < 3; ++i, c += 4) w += mul_wide_portable(le32(c), x[i]);
  } else {
    for (uint8_t i = 0; i < 3; ++i, c += 2) w = mac_portable(w, x[i], le16(c));
  }
  const int32_t y1 = ys[0], y2 = ys[1];
  int32_t acc = round_shift(w, rec[1]);
  int32_t p1 = y1;
  if (fl & blob::kSecDelta) {
    // Delta form: y = 2y1 - y2 - alpha1 (y1 - y2) - alpha0 y2 (poles near z = 1).
    acc += 2 * y1 - y2;
    p1 = y1 - y2;
  } else {
    // Direct form with integer base weights m1, m2 and residues |k| <= 1/2.
    switch ((fl >> 2) & 7) {
      case 0:
        acc -= 2 * y1;
        break;
      case 1:
        acc -= y1;
        break;
      case 3:
        acc += y1;
        break;
      case 4:
        acc += 2 * y1;
        break;
      default:
        break;
    }
    switch ((fl >> 5) & 3) {
      case 0:
        acc -= y2;
        break;
      case 2:
        acc += y2;
        break;
      default:
        break;
    }
  }
  acc += mul_round_portable(p1, le16(c), rec[2]);
  acc += mul_round_portable(y2, le16(c + 2), rec[3]);
  const int32_t y = clamp_state(acc, flags);
  ys[1] = y1;
  ys[0] = y;
  x[0] = q13(y);
  x[1] = q13(y1);
  x[2] = q13(y2);
  return y;
}

#else
// A whole cascade in assembly: `n` section records back to back at `recs` (14 or 20 bytes
// each), the cascade's input x[k] in `x`, its history x[k-1], x[k-2] at `xh` (updated), the
// section states at `ys`. Exactly run_section() applied section after section (checked in
// simavr against the Python reference by tests/quant/test_avr_bitexact.py); returns the last
// section's state and ORs the saturation flag into *flags. One prologue per cascade; the
// section inputs stay in registers.
//   r2 sections left, r3 bits 8..15 of a product, r4 zero, r5 saturation flag,
//   r6-r9 accumulator, r10-r15 section inputs x0 x1 x2 (then y1 in r10-r13, n1 n2 in r14 r15),
//   r16-r19 product operand p (32 bit), r20-r21 operand k (16 bit) / shift count,
//   r22-r25 product >> 16 / rounding shift, X the flags pointer, Y states, Z records.
extern "C" int32_t est_avr_cascade(const uint8_t* recs, uint8_t n, int16_t* xh, int32_t* ys, int16_t x, uint8_t* flags);
asm(R"AVR(
  ; r22-r25 = round(v / 2^s), ties up, for 1 <= s (r20) <= 31: u = floor(v / 2^(s-1)) by byte
  ; moves and 4-2-1 bit steps, then (u + 1) / 2 = (u >> 1) + the bit shifted out
  .macro EST_ROUND
  dec r20
  sbrs r20, 4
  rjmp 1f
  movw r22, r24
  clr r24
  sbrc r23, 7
  com r24
  mov r25, r24
1:
  sbrs r20, 3
  rjmp 2f
  mov r22, r23
  mov r23, r24
  mov r24, r25
  lsl r25
  sbc r25, r25
2:
  sbrs r20, 2
  rjmp 3f
  asr r25
  ror r24
  ror r23
  ror r22
  asr r25
  ror r24
  ror r23
  ror r22
  asr r25
  ror r24
  ror r23
  ror r22
  asr r25
  ror r24
  ror r23
  ror r22
3:
  sbrs r20, 1
  rjmp 4f
  asr r25
  ror r24
  ror r23
  ror r22
  asr r25
  ror r24
  ror r23
  ror r22
4:
  sbrs r20, 0
  rjmp 5f
  asr r25
  ror r24
  ror r23
  ror r22
5:
  asr r25
  ror r24
  ror r23
  ror r22
  adc r22, r4
  adc r23, r4
  adc r24, r4
  adc r25, r4
  .endm

  ; r22-r25 = floor(p k / 2^16), r3 = bits 8..15 of p k: p r16-r19 (signed), k r20-r21
  ; (signed); eight multiplies, the mixed-sign ones sign-extended by sbc of the carry (bit 15).
  .macro EST_MUL48
  mul r16, r20
  mov r3, r1
  mul r18, r20
  movw r22, r0
  muls r19, r21
  movw r24, r0
  mul r17, r20
  add r3, r0
  adc r22, r1
  adc r23, r4
  adc r24, r4
  adc r25, r4
  mulsu r19, r20
  sbc r25, r4
  add r23, r0
  adc r24, r1
  adc r25, r4
  mulsu r21, r16
  sbc r23, r4
  sbc r24, r4
  sbc r25, r4
  add r3, r0
  adc r22, r1
  adc r23, r4
  adc r24, r4
  adc r25, r4
  mulsu r21, r17
  sbc r24, r4
  sbc r25, r4
  add r22, r0
  adc r23, r1
  adc r24, r4
  adc r25, r4
  mulsu r21, r18
  sbc r25, r4
  add r23, r0
  adc r24, r1
  adc r25, r4
  .endm

  ; r6-r9 += round(p k / 2^n), n (16..47) in r14
  .macro EST_FEEDBACK
  EST_MUL48
  mov r20, r14
  subi r20, 16
  brne 6f
  lsl r3
  adc r22, r4
  adc r23, r4
  adc r24, r4
  adc r25, r4
  rjmp 7f
6:
  EST_ROUND
7:
  add r6, r22
  adc r7, r23
  adc r8, r24
  adc r9, r25
  .endm

  ; r6-r9 += r17:r16 * r21:r20 (signed 16 x 16, Atmel AVR201)
  .macro EST_MAC
  muls r17, r21
  add r8, r0
  adc r9, r1
  mul r16, r20
  add r6, r0
  adc r7, r1
  adc r8, r4
  adc r9, r4
  mulsu r17, r20
  sbc r9, r4
  add r7, r0
  adc r8, r1
  adc r9, r4
  mulsu r21, r16
  sbc r9, r4
  add r7, r0
  adc r8, r1
  adc r9, r4
  .endm

  ; floor(v / 2^13) of a state v in place: bytes 1..3 of v in \b1 \lo \hi, shifted left by 3
  .macro EST_Q13 b1, lo, hi
  lsl \b1
  rol \lo
  rol \hi
  lsl \b1
  rol \lo
  rol \hi
  lsl \b1
  rol \lo
  rol \hi
  .endm

  .pushsection .text.est_avr_cascade,"ax",@progbits
  .global est_avr_cascade
  .type est_avr_cascade, @function
est_avr_cascade:
  push r2
  push r3
  push r4
  push r5
  push r6
  push r7
  push r8
  push r9
  push r10
  push r11
  push r12
  push r13
  push r14
  push r15
  push r16
  push r17
  push r28
  push r29
  mov r2, r22
  movw r28, r18
  clr r4
  clr r5
  ; inputs: x0 = x, x1 x2 from the history, which becomes x0 x1; X keeps the flags pointer
  movw r30, r20
  movw r10, r16
  ld r12, Z
  ldd r13, Z+1
  movw r26, r14
  ldd r14, Z+2
  ldd r15, Z+3
  std Z+2, r12
  std Z+3, r13
  st Z, r10
  std Z+1, r11
  movw r30, r24
.Lsec:
  ; numerator w = sum b_i x_i into r6-r9 (T: wide, 32-bit b)
  ld r20, Z
  bst r20, 0
  brtc .Lnarrow
  clr r6
  clr r7
  movw r8, r6
  ldd r16, Z+4
  ldd r17, Z+5
  ldd r18, Z+6
  ldd r19, Z+7
  movw r20, r10
  rcall .Lwacc
  ldd r16, Z+8
  ldd r17, Z+9
  ldd r18, Z+10
  ldd r19, Z+11
  movw r20, r12
  rcall .Lwacc
  ldd r16, Z+12
  ldd r17, Z+13
  ldd r18, Z+14
  ldd r19, Z+15
  movw r20, r14
  rcall .Lwacc
  rjmp .Lnum
.Lnarrow:
  ; the first product fills the accumulator (no carries between its halves)
  movw r16, r10
  ldd r20, Z+4
  ldd r21, Z+5
  muls r17, r21
  movw r8, r0
  mul r16, r20
  movw r6, r0
  mulsu r17, r20
  sbc r9, r4
  add r7, r0
  adc r8, r1
  adc r9, r4
  mulsu r21, r16
  sbc r9, r4
  add r7, r0
  adc r8, r1
  adc r9, r4
  movw r16, r12
  ldd r20, Z+6
  ldd r21, Z+7
  EST_MAC
  movw r16, r14
  ldd r20, Z+8
  ldd r21, Z+9
  EST_MAC
.Lnum:
  ; W = round(w / 2^sb)
  ldd r20, Z+1
  tst r20
  breq 8f
  movw r22, r6
  movw r24, r8
  EST_ROUND
  movw r6, r22
  movw r8, r24
8:
  ; y1 -> r10-r13
  ldd r10, Y+0
  ldd r11, Y+1
  ldd r12, Y+2
  ldd r13, Y+3
  ld r21, Z
  sbrs r21, 1
  rjmp .Ldirect
  ; delta form: p = y1 - y2, acc += y1 + p
  movw r16, r10
  movw r18, r12
  ldd r0, Y+4
  sub r16, r0
  ldd r0, Y+5
  sbc r17, r0
  ldd r0, Y+6
  sbc r18, r0
  ldd r0, Y+7
  sbc r19, r0
  add r6, r10
  adc r7, r11
  adc r8, r12
  adc r9, r13
  add r6, r16
  adc r7, r17
  adc r8, r18
  adc r9, r19
  rjmp .Lterms
.Ldirect:
  ; base weight m1 = bits 2-4 minus 2 on y1
  mov r20, r21
  lsr r20
  lsr r20
  andi r20, 7
  cpi r20, 2
  breq .Lm2
  brlo .Lm1neg
  add r6, r10
  adc r7, r11
  adc r8, r12
  adc r9, r13
  cpi r20, 4
  brne .Lm2
  add r6, r10
  adc r7, r11
  adc r8, r12
  adc r9, r13
  rjmp .Lm2
.Lm1neg:
  sub r6, r10
  sbc r7, r11
  sbc r8, r12
  sbc r9, r13
  tst r20
  brne .Lm2
  sub r6, r10
  sbc r7, r11
  sbc r8, r12
  sbc r9, r13
.Lm2:
  ; base weight m2 = bits 5-6 minus 1 on y2
  ldd r16, Y+4
  ldd r17, Y+5
  ldd r18, Y+6
  ldd r19, Y+7
  sbrc r21, 6
  rjmp .Lm2add
  sbrc r21, 5
  rjmp .Lm2done
  sub r6, r16
  sbc r7, r17
  sbc r8, r18
  sbc r9, r19
  rjmp .Lm2done
.Lm2add:
  add r6, r16
  adc r7, r17
  adc r8, r18
  adc r9, r19
.Lm2done:
  movw r16, r10
  movw r18, r12
.Lterms:
  ; acc += round(p k1 / 2^n1) + round(y2 k2 / 2^n2)
  ldd r14, Z+2
  ldd r15, Z+3
  brtc 8f
  adiw r30, 6
8:
  ldd r20, Z+10
  ldd r21, Z+11
  EST_FEEDBACK
  ldd r16, Y+4
  ldd r17, Y+5
  ldd r18, Y+6
  ldd r19, Y+7
  ldd r20, Z+12
  ldd r21, Z+13
  mov r14, r15
  EST_FEEDBACK
  ; clamp to [-2^28, 2^28 - 1]: in range when bits 28-31 agree
  mov r20, r9
  subi r20, 0xF0
  andi r20, 0xE0
  breq .Lin
  inc r5
  sbrc r9, 7
  rjmp .Lneg
  ldi r20, 0xFF
  mov r6, r20
  mov r7, r20
  mov r8, r20
  ldi r20, 0x0F
  mov r9, r20
  rjmp .Lin
.Lneg:
  clr r6
  clr r7
  clr r8
  ldi r20, 0xF0
  mov r9, r20
.Lin:
  ; next inputs floor(y / 2^13): x2 from y2 (before the states move), x1 from y1, x0 from y
  ldd r0, Y+5
  ldd r14, Y+6
  ldd r15, Y+7
  EST_Q13 r0, r14, r15
  std Y+4, r10
  std Y+5, r11
  std Y+6, r12
  std Y+7, r13
  st Y+, r6
  st Y+, r7
  st Y+, r8
  st Y+, r9
  adiw r28, 4
  EST_Q13 r11, r12, r13
  mov r0, r7
  mov r10, r8
  mov r11, r9
  EST_Q13 r0, r10, r11
  adiw r30, 14
  dec r2
  breq .Ldone
  rjmp .Lsec
.Ldone:
  tst r5
  breq 9f
  ld r20, X
  ori r20, 1
  st X, r20
9:
  movw r22, r6
  movw r24, r8
  clr r1
  pop r29
  pop r28
  pop r17
  pop r16
  pop r15
  pop r14
  pop r13
  pop r12
  pop r11
  pop r10
  pop r9
  pop r8
  pop r7
  pop r6
  pop r5
  pop r4
  pop r3
  pop r2
  ret

  ; r6-r9 += floor(p k / 2^16) (32-bit numerator coefficients)
.Lwacc:
  EST_MUL48
  add r6, r22
  adc r7, r23
  adc r8, r24
  adc r9, r25
  ret
  .size est_avr_cascade, .-est_avr_cascade
  .popsection
)AVR");
#endif

// y[k] + round((x - x[k]) * slope / 2^shift), saturated; seg = slope (i16), shift (u8).
// |x - x[k]| <= 65535 and |slope| <= 32768, so the product fits an int32: sign and magnitude.
ALWAYS_INLINE int16_t interpolate(int16_t x, int16_t xk, int16_t yk, const uint8_t* seg, uint8_t* flags) {
  const int16_t slope = le16(seg);
  const int32_t dx = int32_t(x) - xk;
  const int32_t p = dx >= 0 ? mul_su(slope, uint16_t(dx)) : -mul_su(slope, uint16_t(-dx));
  return sat16(int32_t(yk) + round_shift(p, seg[2]), flags);
}

}  // namespace

Estimator::Estimator() : EstimatorState() {}  // unloaded, states as reset() leaves them

bool Estimator::load(const BlobReader& blob, uint16_t length, uint16_t max_length) {
  if (!blob::validate(blob, length, max_length)) return false;  // the current model stays
  unload();
  blob::read_header(blob, length, &header_, max_length);
  blob_ = &blob;
  length_ = length;
  n_in_ = header_.n_inputs;
  n_out_ = header_.n_outputs;
  reset();
  return true;
}

void Estimator::unload() {
  blob_ = 0;
  length_ = 0;
  n_in_ = n_out_ = 0;
  memset(&header_, 0, sizeof(header_));
}

void Estimator::reset() {
  memset(delay_, 0, sizeof(delay_));
  memset(xhist_, 0, sizeof(xhist_));
  memset(ystate_, 0, sizeof(ystate_));
  head_ = 0;
}

// A compact table's segment: y[k] + (x - x[k]) (y[k+1] - y[k]) / (x[k+1] - x[k]), the quotient
// of the magnitudes rounded half up and given the product's sign; saturated. |x - x[k]| and
// |y[k+1] - y[k]| are below 2^16, so the product fits a uint32.
// c: x[k+1], y[k], y[k+1] as read from the blob. Magnitudes in 16 bits (|x - x[k]| and
// |y[k+1] - y[k]| are below 2^16: unsigned differences of int16 values), one 16x16 product.
static int16_t interpolate_compact(int16_t x, int16_t xk, int16_t yk, const uint8_t* c, uint8_t* flags) {
  const int16_t yk1 = le16(c + 4);
  const uint16_t span = uint16_t(uint16_t(le16(c)) - uint16_t(xk));  // x[k+1] - x[k] > 0
  const bool left = x < xk, down = yk1 < yk;
  const uint16_t adx = left ? uint16_t(uint16_t(xk) - uint16_t(x)) : uint16_t(uint16_t(x) - uint16_t(xk));
  const uint16_t ady = down ? uint16_t(uint16_t(yk) - uint16_t(yk1)) : uint16_t(uint16_t(yk1) - uint16_t(yk));
  uint32_t q = (uint32_t(adx) * ady + (span >> 1)) / span;
  if (q > 0x10000UL) q = 0x10000UL;  // saturates either way; keeps the sum in int32
  return sat16(int32_t(yk) + (left != down ? -int32_t(q) : int32_t(q)), flags);
}

// Table with count byte `count` (n breakpoints, bit 7 compact); off_ is at x[0] (after the
// count byte) and moves past the table.
int16_t Estimator::pwl(uint8_t count, int16_t x) {
  const uint16_t xs = off_;
  const uint8_t n = count & uint8_t(~layout::kTableCompact);
  off_ = uint16_t(xs + blob::pwl_len(count) - 1);
  // Segment k: the last breakpoint <= x among 0..n-2 (segment 0 also left of x[0]), found
  // with steps of 8, 4, 2, 1 (at most 4 reads for 16 breakpoints); the search keeps the x[k]
  // it read, so only x[0] may need a read of its own.
  const uint8_t last = uint8_t(n - 2);
  uint8_t k = 0;
  uint8_t b[3];
  int16_t xk = 0;
  for (uint8_t step = 8; step; step >>= 1) {
    const uint8_t t = uint8_t(k + step);
    if (t > last) continue;
    blob_->read(uint16_t(xs + 2 * t), b, 2);
    const int16_t xt = le16(b);
    if (xt <= x) {
      k = t;
      xk = xt;
    }
  }
  if (k == 0) {
    blob_->read(xs, b, 2);
    xk = le16(b);
  }
  if (count & layout::kTableCompact) {
    uint8_t c[6];
    blob_->read(uint16_t(xs + 2 * k + 2), c, 2);          // x[k+1]
    blob_->read(uint16_t(xs + 2 * n + 2 * k), c + 2, 4);  // y[k], y[k+1]
    return interpolate_compact(x, xk, le16(c + 2), c, &flags_);
  }
  blob_->read(uint16_t(xs + 2 * n + 2 * k), b, 2);
  const int16_t yk = le16(b);
  blob_->read(uint16_t(xs + 4 * n + 3 * k), b, 3);
  return interpolate(x, xk, yk, b, &flags_);
}

inline __attribute__((always_inline)) int32_t Estimator::cascade(uint8_t n, int16_t x) {
  // Every record of the cascade in as few reads as possible: n 16-bit sections first, then
  // 6 more bytes for each wide one met on the walk (the bytes read are always a prefix of
  // the cascade, so each record's flags byte is in the buffer when it is examined).
  uint8_t recs[blob::kMaxSections * blob::kSecLen32];
  uint8_t* end = recs + n * blob::kSecLen16;
  blob_->read(off_, recs, uint8_t(end - recs));
  for (uint8_t* p = recs; p != end;) {
    if (*p & blob::kSecWide) {
      const uint8_t extra = blob::kSecLen32 - blob::kSecLen16;
      blob_->read(uint16_t(off_ + (end - recs)), end, extra);
      end += extra;
      p += blob::kSecLen32;
    } else {
      p += blob::kSecLen16;
    }
  }
  off_ = uint16_t(off_ + (end - recs));
  int16_t* xh = xh_;
  xh_ += 2;
  int32_t* ys = ys_;
  ys_ += 2 * n;
#if defined(__AVR__)
  return est_avr_cascade(recs, n, xh, ys, x, &flags_);
#else
  int16_t xs[3] = {x, xh[0], xh[1]};
  xh[1] = xh[0];
  xh[0] = x;
  int32_t y = 0;
  const uint8_t* rec = recs;
  for (uint8_t s = 0; s < n; ++s, ys += 2) {
    y = run_section(rec, xs, ys, &flags_);
    rec += (rec[0] & blob::kSecWide) ? blob::kSecLen32 : blob::kSecLen16;
  }
  return y;
#endif
}

uint8_t Estimator::step(const int16_t dr_centi[3], int16_t estimate[3]) {
  estimate[0] = estimate[1] = estimate[2] = 0;
  if (!blob_) return 0;
  flags_ = 0;
  head_ = uint8_t((head_ + 1) & (kDelayLen - 1));
  for (uint8_t i = 0; i < n_in_; ++i) delay_[i][head_] = dr_centi[i];
  xh_ = xhist_[0];
  ys_ = ystate_[0];
  off_ = blob::kHeaderLen;
  // A record and the byte after it (a table's breakpoint count or H2's section count) in
  // one read.
  uint8_t rec[blob::kBranchRecLen + 1];
  for (uint8_t j = 0; j < n_out_; ++j) {
    blob_->read(off_, rec, blob::kOutputRecLen);
    off_ = uint16_t(off_ + blob::kOutputRecLen);
    const uint8_t nb = rec[0], ofl = rec[1];
    const int16_t out_offset = le16(rec + 2);
    int32_t sum = 0;  // Q13, |.| <= 3 * 2^28
    for (uint8_t b = 0; b < nb; ++b) {
      blob_->read(off_, rec, blob::kBranchRecLen + 1);
      off_ = uint16_t(off_ + blob::kBranchRecLen);
      int16_t u = delay_[rec[0]][(head_ - rec[1]) & (kDelayLen - 1)];
      int16_t x = sat16(int32_t(u) - le16(rec + 2), &flags_);
      const uint8_t ns = rec[5];
      if (rec[4] & blob::kBranchHasF) {
        off_ = uint16_t(off_ + 1);
        x = pwl(rec[6], x);
      }
      sum += cascade(ns, x);
    }
    int16_t v = sat16(asr(sum, blob::kStateFrac), &flags_);
    if (ofl & (blob::kOutHasG | blob::kOutHasH2)) {
      blob_->read(off_, rec, 1);
      off_ = uint16_t(off_ + 1);
      if (ofl & blob::kOutHasG) {
        v = pwl(rec[0], v);
        if (ofl & blob::kOutHasH2) {
          blob_->read(off_, rec, 1);
          off_ = uint16_t(off_ + 1);
        }
      }
      if (ofl & blob::kOutHasH2) v = q13(cascade(rec[0], v));
    }
    estimate[j] = sat16(int32_t(v) + out_offset, &flags_);
  }
  return flags_;
}

}  // namespace est
