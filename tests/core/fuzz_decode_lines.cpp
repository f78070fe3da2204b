// Differential helper: decodes byte streams given as hex lines on stdin with a fresh
// proto::FrameDecoder each, and prints per line the counters and the frames, so that the
// Python decoder can be compared with this one on any input (tests/protocol).
// Output line: frames bad_cobs bad_crc bad_length bad_version unknown_type overlong
//              then " version:type:seq:payload_hex" per frame ("-" for an empty payload).
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "frame_codec.h"

int main() {
  static char line[1 << 16];
  while (fgets(line, sizeof line, stdin)) {
    proto::FrameDecoder dec;
    static char out[1 << 16];
    size_t used = 0;
    out[0] = 0;
    for (size_t i = 0; line[i] && line[i + 1] && line[i] != '\n'; i += 2) {
      char pair[3] = {line[i], line[i + 1], 0};
      if (!dec.feed((uint8_t)strtoul(pair, nullptr, 16))) continue;
      used += (size_t)snprintf(out + used, sizeof out - used, " %u:%u:%u:", dec.version(), dec.type(), dec.seq());
      for (uint8_t k = 0; k < dec.length() && used + 3 < sizeof out; ++k)
        used += (size_t)snprintf(out + used, sizeof out - used, "%02x", dec.payload()[k]);
      if (dec.length() == 0 && used + 2 < sizeof out) used += (size_t)snprintf(out + used, sizeof out - used, "-");
    }
    const proto::DecoderCounters& c = dec.counters();
    printf("%u %u %u %u %u %u %u%s\n", c.frames, c.bad_cobs, c.bad_crc, c.bad_length, c.bad_version, c.unknown_type,
           c.overlong, out);
  }
  return 0;
}
