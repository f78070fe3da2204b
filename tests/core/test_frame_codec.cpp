// The C++ frame codec against protocol/vectors/frames.txt (read at run time, cwd tests/core),
// plus exhaustive error-detection checks on sample frames. Exit 0 when every check passes.
#include "check.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <string>
#include <vector>

#include "frame_codec.h"

using namespace proto;

namespace {

typedef std::vector<uint8_t> Bytes;

Bytes from_hex(const char* s) {
  Bytes out;
  if (strcmp(s, "-") == 0) return out;
  size_t n = strlen(s);
  for (size_t i = 0; i + 1 < n; i += 2) {
    char pair[3] = {s[i], s[i + 1], 0};
    out.push_back((uint8_t)strtoul(pair, nullptr, 16));
  }
  return out;
}

struct Decoded {
  uint8_t version, type, seq;
  Bytes payload;
};

// Feed every byte; collect frames; check that a frame appears only on a 0x00.
std::vector<Decoded> feed_all(FrameDecoder& dec, const Bytes& stream) {
  std::vector<Decoded> frames;
  for (size_t i = 0; i < stream.size(); ++i) {
    if (dec.feed(stream[i])) {
      CHECK_MSG(stream[i] == 0, "frame reported on a non-delimiter byte at %zu", i);
      Decoded d;
      d.version = dec.version();
      d.type = dec.type();
      d.seq = dec.seq();
      d.payload.assign(dec.payload(), dec.payload() + dec.length());
      frames.push_back(d);
    }
  }
  return frames;
}

bool counters_zero_but_frames(const DecoderCounters& c) {
  return c.bad_cobs == 0 && c.bad_crc == 0 && c.bad_length == 0 && c.bad_version == 0 && c.unknown_type == 0 &&
         c.overlong == 0;
}

void check_crc() {
  const char* s = "123456789";
  CHECK_MSG(crc16((const uint8_t*)s, 9) == 0x6F91, "check value 0x%04X", crc16((const uint8_t*)s, 9));
  // The byte-wise form equals the bit-wise definition on every byte and a few states.
  for (uint32_t state = 0; state < 0x10000; state += 0x1111) {
    for (uint16_t b = 0; b < 256; ++b) {
      uint16_t bitwise = (uint16_t)(state ^ b);
      for (int k = 0; k < 8; ++k)
        bitwise = (bitwise & 1) ? (uint16_t)((bitwise >> 1) ^ 0x8408) : (uint16_t)(bitwise >> 1);
      CHECK_MSG(crc16_update((uint16_t)state, (uint8_t)b) == bitwise, "state %04X byte %02X", (unsigned)state, b);
    }
  }
}

int n_frame_vectors = 0, n_stream_vectors = 0;

void check_frame_vector(const char* name, int version, int type, int seq, const Bytes& payload, const Bytes& frame) {
  ++n_frame_vectors;
  uint8_t out[kMaxFrameLen];
  uint8_t n = encode_frame((uint8_t)type, (uint8_t)seq, payload.empty() ? nullptr : payload.data(),
                           (uint8_t)payload.size(), out, (uint8_t)version);
  CHECK_MSG(n == frame.size() && memcmp(out, frame.data(), n) == 0, "%s: encoding differs (%u vs %zu bytes)", name, n,
            frame.size());
  FrameDecoder dec;
  std::vector<Decoded> got = feed_all(dec, frame);
  CHECK_MSG(got.size() == 1, "%s: %zu frames decoded", name, got.size());
  if (got.size() == 1) {
    CHECK_MSG(got[0].version == version && got[0].type == type && got[0].seq == seq && got[0].payload == payload,
              "%s: decoded fields differ", name);
  }
  CHECK_MSG(dec.counters().frames == 1 && counters_zero_but_frames(dec.counters()), "%s: counters", name);
}

void check_stream_vector(const char* name, const Bytes& stream, const uint16_t want[7],
                         const std::vector<Decoded>& want_frames) {
  ++n_stream_vectors;
  FrameDecoder dec;
  std::vector<Decoded> got = feed_all(dec, stream);
  const DecoderCounters& c = dec.counters();
  const uint16_t have[7] = {c.frames, c.bad_cobs, c.bad_crc, c.bad_length, c.bad_version, c.unknown_type, c.overlong};
  for (int i = 0; i < 7; ++i) CHECK_MSG(have[i] == want[i], "%s: counter %d is %u, want %u", name, i, have[i], want[i]);
  CHECK_MSG(got.size() == want_frames.size(), "%s: %zu frames, want %zu", name, got.size(), want_frames.size());
  for (size_t i = 0; i < got.size() && i < want_frames.size(); ++i) {
    const Decoded& a = got[i];
    const Decoded& b = want_frames[i];
    CHECK_MSG(a.version == b.version && a.type == b.type && a.seq == b.seq && a.payload == b.payload,
              "%s: frame %zu differs", name, i);
  }
}

void check_vectors(const char* path) {
  FILE* f = fopen(path, "r");
  CHECK_MSG(f != nullptr, "cannot open %s", path);
  if (!f) return;
  static char line[8192];
  while (fgets(line, sizeof line, f)) {
    CHECK_MSG(strlen(line) < sizeof line - 1, "line too long");
    if (line[0] == '#' || line[0] == '\n') continue;
    std::vector<std::string> tok;
    for (char* t = strtok(line, " \n"); t; t = strtok(nullptr, " \n")) tok.push_back(t);
    if (tok[0] == "F" && tok.size() == 7) {
      check_frame_vector(tok[1].c_str(), atoi(tok[2].c_str()), atoi(tok[3].c_str()), atoi(tok[4].c_str()),
                         from_hex(tok[5].c_str()), from_hex(tok[6].c_str()));
    } else if (tok[0] == "S" && tok.size() >= 11) {
      uint16_t want[7];
      for (int i = 0; i < 7; ++i) want[i] = (uint16_t)atoi(tok[3 + i].c_str());
      size_t n = (size_t)atoi(tok[10].c_str());
      CHECK_MSG(tok.size() == 11 + 4 * n, "%s: malformed stream line", tok[1].c_str());
      std::vector<Decoded> frames;
      for (size_t i = 0; i < n && 11 + 4 * i + 3 < tok.size(); ++i) {
        Decoded d;
        d.version = (uint8_t)atoi(tok[11 + 4 * i].c_str());
        d.type = (uint8_t)atoi(tok[12 + 4 * i].c_str());
        d.seq = (uint8_t)atoi(tok[13 + 4 * i].c_str());
        d.payload = from_hex(tok[14 + 4 * i].c_str());
        frames.push_back(d);
      }
      check_stream_vector(tok[1].c_str(), from_hex(tok[2].c_str()), want, frames);
    } else {
      CHECK_MSG(false, "unknown vector line starting %s", tok[0].c_str());
    }
  }
  fclose(f);
}

// COBS-encode a body (header|payload|crc) exactly as the encoder would, without its CRC logic.
Bytes cobs(const Bytes& body) {
  Bytes out(1, 0);
  size_t code = 0;
  for (size_t i = 0; i < body.size(); ++i) {
    if (body[i] == 0) {
      out[code] = (uint8_t)(out.size() - code);
      code = out.size();
      out.push_back(0);
    } else {
      out.push_back(body[i]);
    }
  }
  out[code] = (uint8_t)(out.size() - code);
  out.push_back(0);
  return out;
}

Bytes body_of(uint8_t type, uint8_t seq, const Bytes& payload) {
  Bytes body;
  body.push_back(kVersionByte);
  body.push_back(type);
  body.push_back(seq);
  body.push_back((uint8_t)payload.size());
  body.insert(body.end(), payload.begin(), payload.end());
  uint16_t crc = crc16(body.data(), (uint16_t)body.size());
  body.push_back((uint8_t)crc);
  body.push_back((uint8_t)(crc >> 8));
  return body;
}

void flip_burst(Bytes& bytes, size_t first_bit, unsigned len, uint32_t inner) {
  // Burst of len bits: first and last flipped, the len-2 bits between follow `inner`.
  for (unsigned k = 0; k < len; ++k) {
    bool flip = (k == 0 || k == len - 1) ? true : ((inner >> (k - 1)) & 1);
    if (flip) bytes[(first_bit + k) / 8] ^= (uint8_t)(1u << ((first_bit + k) % 8));
  }
}

// Every burst of 1..16 bits in the body (header, payload and CRC; bit i = byte i/8, bit
// i%8, the order a UART sends them) is rejected: the CRC guarantees it, and the search for a
// frame inside the damaged chunk must not bring back a false one.
uint32_t check_body_bursts(uint8_t type, const Bytes& payload, uint32_t* accepted) {
  const Bytes body = body_of(type, 0x5A, payload);
  const size_t bits = body.size() * 8;
  uint32_t tried = 0;
  FrameDecoder dec;
  for (unsigned len = 1; len <= 16; ++len) {
    const uint32_t patterns = len <= 2 ? 1u : (1u << (len - 2));
    for (size_t first = 0; first + len <= bits; ++first) {
      for (uint32_t inner = 0; inner < patterns; ++inner) {
        Bytes bad = body;
        flip_burst(bad, first, len, inner);
        Bytes wire = cobs(bad);
        for (size_t i = 0; i < wire.size(); ++i) {
          if (dec.feed(wire[i])) ++*accepted;
        }
        ++tried;
      }
    }
  }
  return tried;
}

// The same on the wire (the COBS bytes, delimiter excluded). A burst that hits a COBS code
// byte moves where zeros are inserted, so the body error is no longer a burst and only the
// CRC's 1 - 2^-16 applies; the count of accepted frames is measured and must be zero for
// these frames.
uint32_t check_wire_bursts(uint8_t type, const Bytes& payload, uint32_t* accepted) {
  const Bytes wire = cobs(body_of(type, 0x5A, payload));
  const size_t bits = (wire.size() - 1) * 8;
  uint32_t tried = 0;
  FrameDecoder dec;
  for (unsigned len = 1; len <= 16; ++len) {
    const uint32_t patterns = len <= 2 ? 1u : (1u << (len - 2));
    for (size_t first = 0; first + len <= bits; ++first) {
      for (uint32_t inner = 0; inner < patterns; ++inner) {
        Bytes bad = wire;
        flip_burst(bad, first, len, inner);
        dec.feed(0);  // a clean start for every case
        for (size_t i = 0; i < bad.size(); ++i) {
          if (dec.feed(bad[i])) ++*accepted;
        }
        ++tried;
      }
    }
  }
  return tried;
}

void check_encoder_limits() {
  uint8_t out[kMaxFrameLen];
  uint8_t payload[kMaxPayload + 1];
  memset(payload, 0, sizeof payload);
  CHECK_MSG(encode_frame(msg::MODEL_CHUNK, 1, payload, kMaxPayload + 1, out) == 0, "oversized payload accepted");
  CHECK_MSG(encode_frame(msg::PING, 1, nullptr, 4, out) == 0, "null payload accepted");
  // Worst case size: the largest payload, whatever its content, fits kMaxFrameLen.
  for (int fill = 0; fill < 256; fill += 51) {
    memset(payload, fill, sizeof payload);
    uint8_t n = encode_frame(msg::MODEL_CHUNK, 1, payload, kMaxPayload, out);
    CHECK_MSG(n == kMaxPayload + kHeaderLen + kCrcLen + 2 && n <= kMaxFrameLen, "largest frame is %u bytes", n);
  }
}

void check_counters_saturate() {
  FrameDecoder dec;
  const uint8_t bad[] = {0x05, 0x11, 0x22, 0x00};  // bad COBS chain
  for (uint32_t i = 0; i < 70000; ++i) {
    for (size_t k = 0; k < sizeof bad; ++k) dec.feed(bad[k]);
  }
  CHECK_MSG(dec.counters().bad_cobs == 0xFFFF, "bad_cobs is %u after 70000", dec.counters().bad_cobs);
  dec.reset();
  CHECK_MSG(dec.counters().bad_cobs == 0, "reset keeps counters");
}

}  // namespace

int main() {
  check_crc();
  check_encoder_limits();
  check_counters_saturate();
  check_vectors("../../protocol/vectors/frames.txt");
  CHECK_MSG(n_frame_vectors >= 33 && n_stream_vectors >= 10, "only %d frame and %d stream vectors", n_frame_vectors,
            n_stream_vectors);

  const uint8_t ping_payload[] = {0x78, 0x56, 0x34, 0x12};
  const Bytes ping(ping_payload, ping_payload + 4);
  Bytes ack(1, msg::SET_OUTPUTS);
  uint32_t body_accepted = 0, wire_accepted = 0;
  uint32_t body_tried = check_body_bursts(msg::PING, ping, &body_accepted);
  body_tried += check_body_bursts(msg::ACK, ack, &body_accepted);
  uint32_t wire_tried = check_wire_bursts(msg::PING, ping, &wire_accepted);
  wire_tried += check_wire_bursts(msg::ACK, ack, &wire_accepted);
  CHECK_MSG(body_accepted == 0, "%u of %u body bursts accepted", body_accepted, body_tried);
  CHECK_MSG(wire_accepted == 0, "%u of %u wire bursts accepted", wire_accepted, wire_tried);

  printf("frame vectors %d, stream vectors %d\n", n_frame_vectors, n_stream_vectors);
  printf("body bursts <= 16 bits: %u tried, %u accepted\n", body_tried, body_accepted);
  printf("wire bursts <= 16 bits: %u tried, %u accepted\n", wire_tried, wire_accepted);
  printf("%d checks, %d failures\n", g_checks, g_failures);
  return g_failures == 0 ? 0 : 1;
}
