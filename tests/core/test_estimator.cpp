// The fixed-point estimator against the Python bit-exact reference (porosense.quant):
// every case of data/estimator_vectors.txt (or the file given as argv[1]) must give the same
// estimates and flags sample for sample; a reset must reproduce the start of the run.
#include "check.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimator.h"

namespace {

struct Row {
  int16_t u[3];
  int16_t e[3];
  uint8_t flags;
};

bool run_case(FILE* fh, int index, long* samples, long* saturated) {
  unsigned len, n, max_len;
  if (fscanf(fh, " case %u %u %u", &len, &n, &max_len) != 3) return false;
  uint8_t* data = static_cast<uint8_t*>(malloc(len));
  Row* rows = static_cast<Row*>(malloc(sizeof(Row) * (n ? n : 1)));
  for (unsigned i = 0; i < len; ++i) {
    unsigned b;
    if (fscanf(fh, "%2x", &b) != 1) return false;
    data[i] = uint8_t(b);
  }
  for (unsigned t = 0; t < n; ++t) {
    int v[7];
    if (fscanf(fh, "%d %d %d %d %d %d %d", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]) != 7) return false;
    for (int k = 0; k < 3; ++k) {
      rows[t].u[k] = int16_t(v[k]);
      rows[t].e[k] = int16_t(v[3 + k]);
    }
    rows[t].flags = uint8_t(v[6]);
  }
  est::RamBlobReader reader(data, uint16_t(len));
  est::Estimator e;
  CHECK_MSG(e.load(reader, uint16_t(len), uint16_t(max_len)), "case %d: load refused a valid blob", index);
  for (int pass = 0; pass < 2 && e.loaded(); ++pass) {
    unsigned upto = pass == 0 ? n : (n < 64 ? n : 64);  // after reset: the start again
    if (pass == 1) e.reset();
    for (unsigned t = 0; t < upto; ++t) {
      int16_t out[3];
      uint8_t fl = e.step(rows[t].u, out);
      bool same = fl == rows[t].flags && memcmp(out, rows[t].e, sizeof(out)) == 0;
      CHECK_MSG(same, "case %d pass %d sample %u: got %d %d %d flags %u, reference %d %d %d flags %u", index, pass, t,
                out[0], out[1], out[2], fl, rows[t].e[0], rows[t].e[1], rows[t].e[2], rows[t].flags);
      if (!same) break;
      if (pass == 0) {
        ++*samples;
        *saturated += fl & 1;
      }
    }
  }
  // Corrupting any single byte must make load() refuse the blob (CRC or structure).
  for (unsigned i = 0; i < len; i += 7) {
    data[i] ^= 0x5A;
    est::Estimator bad;
    CHECK_MSG(!bad.load(reader, uint16_t(len), uint16_t(max_len)), "case %d: corrupted byte %u accepted", index, i);
    data[i] ^= 0x5A;
  }
  free(data);
  free(rows);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : "data/estimator_vectors.txt";
  FILE* fh = fopen(path, "r");
  if (!fh) {
    printf("FAIL cannot open %s\n", path);
    return 1;
  }
  int cases = 0;
  if (fscanf(fh, " cases %d", &cases) != 1) {
    printf("FAIL bad header in %s\n", path);
    return 1;
  }
  long samples = 0, saturated = 0;
  for (int c = 0; c < cases; ++c) {
    if (!run_case(fh, c, &samples, &saturated)) {
      printf("FAIL parse error in case %d\n", c);
      return 1;
    }
  }
  fclose(fh);
  // An estimator without a model is off: zero estimates, no flags.
  est::Estimator off;
  int16_t in[3] = {100, -200, 300}, out[3] = {1, 1, 1};
  CHECK_MSG(off.step(in, out) == 0 && out[0] == 0 && out[1] == 0 && out[2] == 0, "unloaded estimator not off");
  printf("estimator: %d cases, %ld samples bit-exact (%ld saturated), state RAM %u bytes, object %u bytes\n", cases,
         samples, saturated, unsigned(est::Estimator::kStateBytes), unsigned(sizeof(est::Estimator)));
  if (cases < 1 || samples < 1) {
    printf("FAIL no vectors\n");
    return 1;
  }
  return g_failures ? 1 : 0;
}
