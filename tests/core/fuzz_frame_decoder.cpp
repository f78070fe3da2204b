// Fuzz driver of proto::FrameDecoder, built with AddressSanitizer and UndefinedBehaviorSanitizer
// (tests/core/Makefile.fuzz). Deterministic: a seeded generator builds streams of valid frames
// and damages them (bit flips, byte insertions and deletions, truncations, garbage with and
// without 0x00 between frames, overlong runs, pure noise), then feeds them byte by byte.
//
// Invariants checked on every input:
//   - no sanitizer finding (any finding aborts the program);
//   - a frame reported valid is valid: its type is known, its major ours and its length within
//     the type's bounds (HELLO/HELLO_REPLY of another major exempt), and re-encoding it gives exactly the last
//     bytes of the chunk it came from (so the decoder never invents bytes);
//   - each non-empty chunk yields at most one frame and is accounted for: a frame, or one
//     drop counter, or the overlong counter;
//   - an undamaged frame that follows garbage (any length, with or without 0x00) is decoded.
//
// Usage: fuzz_frame_decoder [inputs=100000] [seed=1]; prints one JSON line of figures.
// With -DPOROSENSE_LIBFUZZER the same checks run as a libFuzzer target instead.
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "frame_codec.h"

using namespace proto;

namespace {

void fail(const char* what, uint64_t input) {
  fprintf(stderr, "fuzz invariant violated on input %llu: %s\n", (unsigned long long)input, what);
  abort();
}

uint32_t drops(const DecoderCounters& c) {
  return (uint32_t)c.bad_cobs + c.bad_crc + c.bad_length + c.bad_version + c.unknown_type;
}

// Feeds a stream and checks the per-frame and per-chunk invariants. Returns frames decoded;
// `frames_at` receives the stream index of each frame's delimiter (up to max_at entries).
struct Checker {
  FrameDecoder dec;
  uint8_t chunk[4096];
  uint32_t chunk_len = 0;
  uint64_t frames = 0, chunks = 0;

  uint32_t feed(const uint8_t* data, size_t n, uint64_t input, uint32_t* frames_at, uint32_t max_at) {
    uint32_t found = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint8_t b = data[i];
      const DecoderCounters before = dec.counters();
      const bool ok = dec.feed(b);
      const DecoderCounters& after = dec.counters();
      if (b != 0) {
        if (ok) fail("frame reported on a non-zero byte", input);
        if (chunk_len == sizeof chunk) {  // keep the tail: only it can hold a frame
          memmove(chunk, chunk + sizeof chunk / 2, sizeof chunk / 2);
          chunk_len = sizeof chunk / 2;
        }
        chunk[chunk_len++] = b;
        continue;
      }
      if (chunk_len > 0) {
        ++chunks;
        const uint32_t new_frames = (uint32_t)(after.frames - before.frames);
        const uint32_t new_drops = drops(after) - drops(before);
        if (before.frames != 0xFFFF && new_frames != (ok ? 1u : 0u)) fail("frames counter disagrees", input);
        if (new_drops > 1) fail("one chunk counted twice", input);
        const bool saturated = before.frames == 0xFFFF || drops(before) >= 0xFFFF;
        if (!saturated && !ok && new_drops == 0 && chunk_len <= kMaxFrameLen) fail("chunk not accounted", input);
      } else if (ok) {
        fail("frame from an empty chunk", input);
      }
      if (ok) {
        check_frame(input);
        if (found < max_at && frames_at) frames_at[found] = (uint32_t)i;
        ++found;
        ++frames;
      }
      chunk_len = 0;
    }
    return found;
  }

  void check_frame(uint64_t input) {
    uint8_t min_len, max_len;
    if (!payload_bounds(dec.type(), &min_len, &max_len)) fail("unknown type delivered", input);
    const bool foreign = (dec.version() >> 4) != kVersionMajor;
    if (foreign && dec.type() != msg::HELLO && dec.type() != msg::HELLO_REPLY) fail("foreign major delivered", input);
    if (!foreign && (dec.length() < min_len || dec.length() > max_len)) fail("length outside bounds delivered", input);
    // Copy first: payload() points into the decoder's buffer.
    uint8_t payload[kMaxPayload];
    memcpy(payload, dec.payload(), dec.length());
    uint8_t enc[kMaxFrameLen];
    const uint8_t n = encode_frame(dec.type(), dec.seq(), payload, dec.length(), enc, dec.version());
    if (n == 0 || n - 1u > chunk_len) fail("re-encoded frame longer than its chunk", input);
    if (memcmp(enc, chunk + chunk_len - (n - 1), n - 1) != 0)
      fail("re-encoded frame differs from the received bytes", input);
  }
};

}  // namespace

#ifdef POROSENSE_LIBFUZZER

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Checker checker;
  checker.feed(data, size, 0, nullptr, 0);
  return 0;
}

#else

namespace {

uint64_t rng_state = 1;
uint32_t rnd() {  // xorshift64*
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return (uint32_t)((rng_state * 2685821657736338717ULL) >> 32);
}
uint32_t below(uint32_t n) { return n ? rnd() % n : 0; }

uint8_t known_types[256];
uint8_t n_known = 0;

// A valid frame of a random known type and a random allowed length; returns its length.
uint8_t random_frame(uint8_t* out, bool zero_heavy, bool any_version = false) {
  const uint8_t type = known_types[below(n_known)];
  uint8_t lo, hi;
  payload_bounds(type, &lo, &hi);
  const uint8_t len = (uint8_t)(lo + below(hi - lo + 1u));
  uint8_t payload[kMaxPayload];
  for (uint8_t i = 0; i < len; ++i) payload[i] = zero_heavy && below(2) ? 0 : (uint8_t)rnd();
  uint8_t version = kVersionByte;
  if (below(16) == 0) version = (uint8_t)((kVersionMajor << 4) | below(16));  // another minor
  if (any_version && below(16) == 0) version = (uint8_t)rnd();                // mostly another major
  return encode_frame(type, (uint8_t)rnd(), payload, len, out, version);
}

size_t garbage(uint8_t* out, size_t room, bool allow_zero) {
  size_t n = below(4) == 0 ? below(400) : below(40);
  if (n > room) n = room;
  for (size_t i = 0; i < n; ++i) {
    uint8_t b = (uint8_t)rnd();
    if (!allow_zero && b == 0) b = 0x5A;
    out[i] = b;
  }
  return n;
}

// Damage a stream in place: flips, insertions, deletions, truncation. Returns its new length.
size_t mutate(uint8_t* s, size_t n, size_t cap) {
  const uint32_t edits = 1 + below(6);
  for (uint32_t e = 0; e < edits && n > 0; ++e) {
    const size_t at = below((uint32_t)n);
    switch (below(6)) {
      case 0:
      case 1:
        s[at] ^= (uint8_t)(1u << below(8));
        break;  // bit flip
      case 2:
        s[at] = (uint8_t)rnd();
        break;  // byte replaced
      case 3:   // insertion
        if (n < cap) {
          memmove(s + at + 1, s + at, n - at);
          s[at] = (uint8_t)rnd();
          ++n;
        }
        break;
      case 4:
        memmove(s + at, s + at + 1, n - at - 1);
        --n;
        break;  // deletion
      default:
        n = at + 1;
        break;  // truncation
    }
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  const uint64_t inputs = argc > 1 ? strtoull(argv[1], nullptr, 10) : 100000;
  rng_state = 0x9E3779B97F4A7C15ULL ^ (argc > 2 ? strtoull(argv[2], nullptr, 10) : 1);
  for (int t = 0; t < 256; ++t) {
    uint8_t lo, hi;
    if (payload_bounds((uint8_t)t, &lo, &hi)) known_types[n_known++] = (uint8_t)t;
  }
  static uint8_t stream[8192];
  uint64_t bytes = 0, recovered = 0, expected = 0, frames_total = 0;
  Checker persistent;  // carries state from one input to the next, like a long-lived link
  for (uint64_t input = 0; input < inputs; ++input) {
    size_t n = 0;
    const uint32_t kind = below(8);
    uint32_t want_at[8];  // delimiter index of each undamaged frame that must decode
    uint32_t n_want = 0;
    if (kind == 0) {  // pure noise, zeros rare or common
      const size_t len = below(600);
      const bool zeros = below(2);
      for (size_t i = 0; i < len; ++i) stream[n++] = zeros ? (uint8_t)rnd() : (uint8_t)(1 + below(255));
    } else if (kind <= 3) {  // frames, then the whole stream damaged
      const uint32_t k = 1 + below(4);
      for (uint32_t f = 0; f < k; ++f) n += random_frame(stream + n, below(2), true);
      n = mutate(stream, n, sizeof stream);
    } else {  // garbage then an undamaged frame, repeated: every such frame must come out
      const uint32_t k = 1 + below(4);
      stream[n++] = 0;  // the garbage starts a new chunk
      for (uint32_t f = 0; f < k; ++f) {
        const size_t g0 = n;
        size_t glen = garbage(stream + g0, sizeof stream - g0 - 2 * kMaxFrameLen, kind != 4);
        if (kind == 7) glen = mutate(stream + g0, glen, glen + 8);  // damaged copies of garbage
        n = g0 + glen;
        n += random_frame(stream + n, below(2));
        want_at[n_want++] = (uint32_t)(n - 1);
      }
    }
    bytes += n;
    Checker fresh;
    uint32_t got_at[16];
    const uint32_t got = fresh.feed(stream, n, input, got_at, 16);
    frames_total += got;
    // Each undamaged frame's delimiter must be where a frame was reported.
    for (uint32_t w = 0; w < n_want; ++w) {
      ++expected;
      bool hit = false;
      for (uint32_t g = 0; g < got && g < 16; ++g) hit = hit || got_at[g] == want_at[w];
      if (!hit) fail("an undamaged frame after garbage was not decoded", input);
      ++recovered;
    }
    persistent.feed(stream, n, input, nullptr, 0);
  }
  printf(
      "{\"inputs\": %llu, \"bytes\": %llu, \"frames\": %llu, \"frames_after_garbage\": %llu, "
      "\"recovered_after_garbage\": %llu, \"chunks\": %llu}\n",
      (unsigned long long)inputs, (unsigned long long)bytes, (unsigned long long)frames_total,
      (unsigned long long)expected, (unsigned long long)recovered, (unsigned long long)persistent.chunks);
  return 0;
}

#endif
