// The EEPROM model store: protocol result codes, CRC and structure checks, corruption of
// every stored byte, and a reset (torn write) at every write of a flash sequence, which
// must leave the old model or no model, never a broken one.
#include "check.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimator.h"
#include "frame_codec.h"
#include "model_store.h"

namespace {


namespace res = proto::result;

// 1 KB EEPROM that can "lose power": after `budget` writes every further write is dropped,
// and the write that hits the budget may be torn (stores a garbage value).
class FakeEeprom : public est::Eeprom {
 public:
  uint8_t mem[1024];
  long writes = 0, budget = -1;
  bool torn = false;
  FakeEeprom() { memset(mem, 0xFF, sizeof(mem)); }
  uint8_t read(uint16_t a) override { return a < 1024 ? mem[a] : 0xFF; }
  void write(uint16_t a, uint8_t v) override {
    if (budget >= 0 && writes >= budget) {
      if (torn && writes == budget && a < 1024) mem[a] = uint8_t(v ^ 0xA5);
      ++writes;
      return;
    }
    ++writes;
    if (a < 1024) mem[a] = v;
  }
};

struct Blob {
  uint8_t data[952];
  uint16_t len;
  int16_t u[64][3], e[64][3];
  uint16_t crc() const { return uint16_t(data[len - 2] | data[len - 1] << 8); }
};

// The first blobs of the estimator vectors that fit the EEPROM, with their reference rows.
int load_blobs(Blob* out, int want) {
  FILE* fh = fopen("data/estimator_vectors.txt", "r");
  if (!fh) return 0;
  int cases = 0, got = 0;
  if (fscanf(fh, " cases %d", &cases) != 1) return 0;
  for (int c = 0; c < cases && got < want; ++c) {
    unsigned len, n, maxlen;
    if (fscanf(fh, " case %u %u %u", &len, &n, &maxlen) != 3) break;
    static uint8_t buf[4096];
    for (unsigned i = 0; i < len; ++i) { unsigned b; if (fscanf(fh, "%2x", &b) != 1) return got; buf[i] = uint8_t(b); }
    Blob& bl = out[got];
    for (unsigned t = 0; t < n; ++t) {
      int v[7];
      if (fscanf(fh, "%d %d %d %d %d %d %d", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]) != 7) return got;
      if (t < 64) for (int k = 0; k < 3; ++k) { bl.u[t][k] = int16_t(v[k]); bl.e[t][k] = int16_t(v[3 + k]); }
    }
    if (len <= 952 && n >= 64) { memcpy(bl.data, buf, len); bl.len = uint16_t(len); ++got; }
  }
  fclose(fh);
  return got;
}

bool flash(est::ModelStore& st, const Blob& b) {
  int16_t d;
  if (st.begin(b.len, b.crc(), 1, &d) != res::OK) return false;
  for (uint16_t off = 0; off < b.len; off = uint16_t(off + 112)) {
    uint8_t n = uint8_t(b.len - off > 112 ? 112 : b.len - off);
    if (st.chunk(off, b.data + off, n, &d) != res::OK) return false;
  }
  return st.commit(&d) == res::OK;
}

bool runs_like(est::Estimator& e, const Blob& b) {
  e.reset();
  for (int t = 0; t < 64; ++t) {
    int16_t out[3];
    e.step(b.u[t], out);
    if (memcmp(out, b.e[t], sizeof(out)) != 0) return false;
  }
  return true;
}

}  // namespace

int main() {
  static Blob blobs[2];
  if (load_blobs(blobs, 2) < 2) { printf("FAIL need two blobs in data/estimator_vectors.txt\n"); return 1; }
  const Blob &A = blobs[0], &B = blobs[1];

  // Empty EEPROM: no model, estimator off.
  {
    FakeEeprom ee; est::Estimator e; est::ModelStore st(ee, e);
    st.boot();
    CHECK_MSG(st.status() == 0 && !e.loaded(), "blank EEPROM: status %u", st.status());
    uint8_t buf[4];
    CHECK_MSG(st.read(0, 4, buf) == res::NO_MODEL, "read without a model");
  }
  // Flash, reboot, info, read back.
  FakeEeprom base; 
  {
    est::Estimator e; est::ModelStore st(base, e);
    st.boot();
    CHECK_MSG(flash(st, A), "flashing a valid blob failed");
    CHECK_MSG(st.status() == 1 && e.loaded() && st.crc() == A.crc(), "after commit");
    est::Estimator e2; est::ModelStore st2(base, e2);
    st2.boot();
    CHECK_MSG(st2.status() == 1 && st2.crc() == A.crc() && st2.length() == A.len, "after reboot: status %u", st2.status());
    CHECK_MSG(runs_like(e2, A), "estimator from EEPROM differs from the reference");
    proto::ModelInfoReply info;
    st2.info(&info);
    CHECK_MSG(info.status == 1 && info.length == A.len && info.crc == A.crc() && info.format_version == 1 &&
          info.n_inputs == A.data[3] && info.n_outputs == A.data[4], "MODEL_INFO fields");
    uint8_t buf[112];
    CHECK_MSG(st2.read(0, 112, buf) == res::OK && memcmp(buf, A.data, 112) == 0, "MODEL_READ content");
    CHECK_MSG(st2.read(uint16_t(A.len - 1), 2, buf) == res::OUT_OF_RANGE, "MODEL_READ past the end");
  }
  // Result codes.
  {
    FakeEeprom ee = base; est::Estimator e; est::ModelStore st(ee, e);
    st.boot();
    int16_t d = 0;
    CHECK_MSG(st.begin(1000, 0, 1, &d) == res::TOO_LARGE && d == 48, "TOO_LARGE detail %d", d);
    CHECK_MSG(st.status() == 1, "a refused BEGIN must keep the model");
    CHECK_MSG(st.begin(100, 0, 2, &d) == res::BAD_MODEL, "format version 2 accepted");
    CHECK_MSG(st.chunk(0, A.data, 10, &d) == res::BAD_STATE, "CHUNK without BEGIN");
    CHECK_MSG(st.commit(&d) == res::BAD_STATE, "COMMIT without BEGIN");
    CHECK_MSG(st.begin(A.len, A.crc(), 1, &d) == res::OK && st.status() == 0 && !e.loaded(), "BEGIN invalidates");
    CHECK_MSG(st.chunk(0, A.data, 100, &d) == res::OK, "first chunk");
    CHECK_MSG(st.chunk(50, A.data, 10, &d) == res::BAD_STATE && d == 100, "non-contiguous chunk detail %d", d);
    CHECK_MSG(st.commit(&d) == res::BAD_STATE && d == 100, "early COMMIT detail %d", d);
    CHECK_MSG(st.chunk(100, A.data, 112, &d) == (A.len >= 212 ? res::OK : res::TOO_LARGE), "second chunk");
    // Wrong CRC announced at BEGIN.
    CHECK_MSG(st.begin(A.len, uint16_t(A.crc() ^ 1), 1, &d) == res::OK, "begin");
    for (uint16_t off = 0; off < A.len; off = uint16_t(off + 100))
      st.chunk(off, A.data + off, uint8_t(A.len - off > 100 ? 100 : A.len - off), &d);
    CHECK_MSG(st.commit(&d) == res::BAD_MODEL && st.status() == 0 && !e.loaded(), "bad CRC accepted");
    // Valid CRC, broken structure (n_outputs = 4).
    Blob bad = A;
    bad.data[4] = 4;
    uint16_t c = proto::crc16(bad.data, uint16_t(bad.len - 2));
    bad.data[bad.len - 2] = uint8_t(c & 0xFF);
    bad.data[bad.len - 1] = uint8_t(c >> 8);
    CHECK_MSG(!flash(st, bad) && st.status() == 0 && !e.loaded(), "structurally bad blob accepted");
    est::ModelStore st2(ee, e);
    st2.boot();
    CHECK_MSG(st2.status() == 0, "after failed commits: status %u", st2.status());
    CHECK_MSG(flash(st, B) && st.erase() == res::OK && st.status() == 0 && !e.loaded(), "erase");
    st2.boot();
    CHECK_MSG(st2.status() == 0, "erased model came back");
  }
  // Corruption of every stored byte: the model must come back invalid (or absent), never run.
  int corrupt_checked = 0;
  for (uint16_t a = est::ModelStore::kBase; a < est::ModelStore::kBlobBase + A.len; ++a) {
    FakeEeprom ee = base;
    ee.mem[a] ^= 0x10;
    est::Estimator e; est::ModelStore st(ee, e);
    st.boot();
    bool magic = a < est::ModelStore::kBase + 2;
    CHECK_MSG(st.status() == (magic ? 0 : 2) && !e.loaded(), "byte %u corrupted: status %u", a, st.status());
    ++corrupt_checked;
  }
  // Reset at every write of flashing B over A, clean and torn.
  long total = 0;
  {
    FakeEeprom ee = base; est::Estimator e; est::ModelStore st(ee, e);
    ee.writes = 0;
    st.boot();
    CHECK_MSG(flash(st, B), "flash B");
    total = ee.writes;
  }
  int old_seen = 0, none_seen = 0, new_seen = 0;
  for (int torn = 0; torn < 2; ++torn) {
    for (long k = 0; k <= total; ++k) {
      FakeEeprom ee = base;
      ee.writes = 0;
      ee.budget = k;
      ee.torn = torn;
      {
        est::Estimator e; est::ModelStore st(ee, e);
        st.boot();
        flash(st, B);
      }
      est::Estimator e; est::ModelStore st(ee, e);
      st.boot();
      if (st.status() == 1) {
        bool is_old = st.crc() == A.crc(), is_new = st.crc() == B.crc();
        CHECK_MSG(is_old || is_new, "reset at write %ld: a model that is neither old nor new", k);
        CHECK_MSG(!is_new || k >= total, "reset at write %ld: new model valid before the last write", k);
        CHECK_MSG(runs_like(e, is_old ? A : B), "reset at write %ld: stored model runs differently", k);
        old_seen += is_old;
        new_seen += is_new;
      } else {
        CHECK_MSG(st.status() == 0 && !e.loaded(), "reset at write %ld (torn %d): status %u", k, torn, st.status());
        ++none_seen;
      }
    }
  }
  CHECK_MSG(new_seen >= 1 && old_seen >= 1 && none_seen >= 1, "torn-write outcomes old %d none %d new %d",
        old_seen, none_seen, new_seen);
  printf("model store: %d corrupted bytes refused; resets at %ld write positions x2 (clean/torn): "
         "old model %d, no model %d, new model %d, broken 0\n",
         corrupt_checked, total + 1, old_seen, none_seen, new_seen);
  return g_failures ? 1 : 0;
}
