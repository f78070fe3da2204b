// Throughput of the C++ frame codec on the host (built with -O2 by the Makefile next to it,
// run by porosense.bench.protocol). Encodes and decodes SAMPLE frames with varied content;
// prints one JSON object: frames per second for encode and for byte-by-byte decode.
//
// Usage: codec_bench [frames=200000]
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <chrono>
#include <vector>

#include "frame_codec.h"

using namespace proto;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void make_sample(uint32_t i, uint8_t* payload) {
  Sample s;
  s.t_us = i * 5000u;
  s.channel_mask = 0x1F;
  s.status = (uint16_t)(i & 0x0F);
  for (int c = 0; c < 3; ++c) {
    s.adc[c] = (int16_t)(20000 + (int32_t)((i * 37u + c * 11u) % 4000));
    s.dr_centi[c] = (int16_t)(-((int32_t)(i * 13u + c) % 8000));
    s.euler_16[c] = (int16_t)((int32_t)(i * 7u + c * 100u) % 5760);
    s.estimate[c] = (int16_t)((int32_t)(i * 3u + c) % 30000);
  }
  s.encode(payload);
}

}  // namespace

int main(int argc, char** argv) {
  const uint32_t n = argc > 1 ? (uint32_t)strtoul(argv[1], nullptr, 10) : 200000;
  // Payloads prepared first, so that only the codec is timed.
  const uint32_t distinct = 1024;
  std::vector<uint8_t> payloads(distinct * Sample::kMinLen);
  for (uint32_t i = 0; i < distinct; ++i) make_sample(i, &payloads[i * Sample::kMinLen]);

  uint8_t out[kMaxFrameLen];
  uint32_t checksum = 0;
  auto t0 = std::chrono::steady_clock::now();
  for (uint32_t i = 0; i < n; ++i) {
    const uint8_t len =
        encode_frame(msg::SAMPLE, (uint8_t)i, &payloads[(i % distinct) * Sample::kMinLen], Sample::kMinLen, out);
    checksum += out[len - 2] + len;
  }
  const double t_encode = seconds_since(t0);

  std::vector<uint8_t> stream;
  for (uint32_t i = 0; i < distinct; ++i) {
    const uint8_t len = encode_frame(msg::SAMPLE, (uint8_t)i, &payloads[i * Sample::kMinLen], Sample::kMinLen, out);
    stream.insert(stream.end(), out, out + len);
  }
  const size_t frame_bytes = stream.size() / distinct;
  FrameDecoder dec;
  uint32_t decoded = 0;
  const uint32_t rounds = (n + distinct - 1) / distinct;
  t0 = std::chrono::steady_clock::now();
  for (uint32_t r = 0; r < rounds; ++r) {
    for (size_t k = 0; k < stream.size(); ++k) {
      if (dec.feed(stream[k])) {
        ++decoded;
        checksum += dec.payload()[0];
      }
    }
  }
  const double t_decode = seconds_since(t0);
  if (decoded != rounds * distinct) {
    fprintf(stderr, "decoded %u of %u frames\n", decoded, rounds * distinct);
    return 1;
  }
  printf(
      "{\"frames\": %u, \"sample_frame_bytes\": %zu, \"encode_frames_per_s\": %.0f, "
      "\"decode_frames_per_s\": %.0f, \"checksum\": %u}\n",
      n, frame_bytes, n / t_encode, decoded / t_decode, checksum);
  return 0;
}
