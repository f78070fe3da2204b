// The two-slot EEPROM model store: protocol result codes, CRC and structure checks, corruption
// of every stored byte, and a reset (clean or torn write) at every write of a flash sequence,
// which must leave the old model running (or the new one once whole), never no model and never
// a broken one.
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
  uint8_t data[est::layout::kMaxBlobLength];
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
    for (unsigned i = 0; i < len; ++i) {
      unsigned b;
      if (fscanf(fh, "%2x", &b) != 1) return got;
      buf[i] = uint8_t(b);
    }
    Blob& bl = out[got];
    for (unsigned t = 0; t < n; ++t) {
      int v[7];
      if (fscanf(fh, "%d %d %d %d %d %d %d", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]) != 7) return got;
      if (t < 64)
        for (int k = 0; k < 3; ++k) {
          bl.u[t][k] = int16_t(v[k]);
          bl.e[t][k] = int16_t(v[3 + k]);
        }
    }
    if (len <= est::layout::kMaxBlobLength / 2 && n >= 64) {
      memcpy(bl.data, buf, len);
      bl.len = uint16_t(len);
      ++got;
    }
  }
  fclose(fh);
  return got;
}

bool flash(est::ModelStore& st, const Blob& b) {
  int16_t d;
  if (st.begin(b.len, b.crc(), est::layout::kFormatVersion, &d) != res::OK) return false;
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
  const uint8_t V = est::layout::kFormatVersion;
  static Blob blobs[2];
  if (load_blobs(blobs, 2) < 2) {
    printf("FAIL need two blobs in data/estimator_vectors.txt\n");
    return 1;
  }
  const Blob &A = blobs[0], &B = blobs[1];
  CHECK_MSG(A.crc() != B.crc(), "the two test blobs must differ");

  // Empty EEPROM: no model, estimator off.
  {
    FakeEeprom ee;
    est::Estimator e;
    est::ModelStore st(ee, e);
    st.boot();
    CHECK_MSG(st.status() == 0 && !e.loaded(), "blank EEPROM: status %u", st.status());
    uint8_t buf[4];
    CHECK_MSG(st.read(0, 4, buf) == res::NO_MODEL, "read without a model");
    CHECK_MSG(st.room() == est::layout::kMaxBlobLength, "room of an empty store %u", st.room());
  }
  // Flash, reboot, info, read back.
  FakeEeprom base;  // A in slot 0
  {
    est::Estimator e;
    est::ModelStore st(base, e);
    st.boot();
    CHECK_MSG(flash(st, A), "flashing a valid blob failed");
    CHECK_MSG(st.status() == 1 && e.loaded() && st.crc() == A.crc() && st.active_slot() == 0, "after commit");
    est::Estimator e2;
    est::ModelStore st2(base, e2);
    st2.boot();
    CHECK_MSG(st2.status() == 1 && st2.crc() == A.crc() && st2.length() == A.len, "after reboot: status %u",
              st2.status());
    CHECK_MSG(runs_like(e2, A), "estimator from EEPROM differs from the reference");
    proto::ModelInfoReply info;
    st2.info(&info);
    CHECK_MSG(info.status == 1 && info.length == A.len && info.crc == A.crc() && info.format_version == V &&
                  info.n_inputs == A.data[3] && info.n_outputs == A.data[4],
              "MODEL_INFO fields");
    uint8_t buf[112];
    CHECK_MSG(st2.read(0, 112, buf) == res::OK && memcmp(buf, A.data, 112) == 0, "MODEL_READ content");
    CHECK_MSG(st2.read(uint16_t(A.len - 1), 2, buf) == res::OUT_OF_RANGE, "MODEL_READ past the end");
  }
  FakeEeprom both = base;  // A in slot 0 (older), B in slot 1 (running)
  {
    est::Estimator e;
    est::ModelStore st(both, e);
    st.boot();
    CHECK_MSG(flash(st, B) && st.active_slot() == 1 && st.crc() == B.crc() && runs_like(e, B), "B beside A");
    est::Estimator e2;
    est::ModelStore st2(both, e2);
    st2.boot();
    CHECK_MSG(st2.crc() == B.crc() && st2.active_slot() == 1 && runs_like(e2, B), "after reboot B runs");
  }
  // Result codes; every refusal keeps the running model.
  {
    FakeEeprom ee = base;
    est::Estimator e;
    est::ModelStore st(ee, e);
    st.boot();
    int16_t d = 0;
    uint16_t room = st.room();
    CHECK_MSG(room == est::layout::kMaxBlobLength - A.len, "room beside A %u", room);
    CHECK_MSG(st.begin(uint16_t(room + 48), 0, V, &d) == res::TOO_LARGE && d == 48, "TOO_LARGE detail %d", d);
    CHECK_MSG(st.status() == 1, "a refused BEGIN must keep the model");
    CHECK_MSG(st.begin(100, 0, uint8_t(V + 1), &d) == res::BAD_MODEL, "another format version accepted");
    CHECK_MSG(st.begin(100, 0, 1, &d) == res::BAD_MODEL, "format version 1 accepted");
    CHECK_MSG(st.chunk(0, A.data, 10, &d) == res::BAD_STATE, "CHUNK without BEGIN");
    CHECK_MSG(st.commit(&d) == res::BAD_STATE, "COMMIT without BEGIN");
    CHECK_MSG(st.begin(B.len, B.crc(), V, &d) == res::OK && st.status() == 1 && e.loaded() && st.crc() == A.crc(),
              "BEGIN must keep the running model");
    CHECK_MSG(st.chunk(0, B.data, 100, &d) == res::OK, "first chunk");
    CHECK_MSG(runs_like(e, A), "the running model changed during a write");
    CHECK_MSG(st.chunk(50, B.data, 10, &d) == res::BAD_STATE && d == 100, "non-contiguous chunk detail %d", d);
    CHECK_MSG(st.commit(&d) == res::BAD_STATE && d == 100, "early COMMIT detail %d", d);
    CHECK_MSG(st.chunk(100, B.data + 100, 112, &d) == (B.len >= 212 ? res::OK : res::TOO_LARGE), "second chunk");
    // Wrong CRC announced at BEGIN.
    CHECK_MSG(st.begin(B.len, uint16_t(B.crc() ^ 1), V, &d) == res::OK, "begin");
    for (uint16_t off = 0; off < B.len; off = uint16_t(off + 100))
      st.chunk(off, B.data + off, uint8_t(B.len - off > 100 ? 100 : B.len - off), &d);
    CHECK_MSG(st.commit(&d) == res::BAD_MODEL && st.status() == 1 && st.crc() == A.crc() && runs_like(e, A),
              "bad CRC: the old model must keep running");
    // Valid CRC, broken structure (n_outputs = 4).
    Blob bad = B;
    bad.data[4] = 4;
    uint16_t c = proto::crc16(bad.data, uint16_t(bad.len - 2));
    bad.data[bad.len - 2] = uint8_t(c & 0xFF);
    bad.data[bad.len - 1] = uint8_t(c >> 8);
    CHECK_MSG(!flash(st, bad) && st.status() == 1 && st.crc() == A.crc() && runs_like(e, A),
              "structurally bad blob: the old model must keep running");
    est::Estimator e2;
    est::ModelStore st2(ee, e2);
    st2.boot();
    CHECK_MSG(st2.status() == 1 && st2.crc() == A.crc() && runs_like(e2, A), "after failed commits: status %u",
              st2.status());
    CHECK_MSG(flash(st, B) && flash(st, A) && st.active_slot() == 0 && runs_like(e, A), "A again, in slot 0");
    CHECK_MSG(st.erase() == res::OK && st.status() == 0 && !e.loaded(), "erase");
    st2.boot();
    CHECK_MSG(st2.status() == 0, "erased model came back");
  }
  // A blob that does not fit beside the running one is refused, and the running one stays.
  {
    FakeEeprom ee = base;
    est::Estimator e;
    est::ModelStore st(ee, e);
    st.boot();
    int16_t d = 0;
    uint16_t big = uint16_t(est::layout::kMaxBlobLength - A.len + 1);
    CHECK_MSG(st.begin(big, 0, V, &d) == res::TOO_LARGE && d == 1 && runs_like(e, A), "no room beside A");
  }
  // Corruption of every stored byte of the running model: with no other model it comes back
  // invalid (or absent), never runs; with an older model beside it, the older one runs.
  int corrupt_checked = 0;
  {
    const uint16_t hdr = est::ModelStore::kBase;
    for (uint16_t a = hdr; a < est::ModelStore::kAreaBase + A.len; ++a) {
      if (a >= hdr + est::layout::kSlotHeaderLen && a < est::ModelStore::kAreaBase) continue;  // slot 1's header
      FakeEeprom ee = base;
      ee.mem[a] ^= 0x10;
      est::Estimator e;
      est::ModelStore st(ee, e);
      st.boot();
      bool magic = a == hdr;
      CHECK_MSG(st.status() == (magic ? 0 : 2) && !e.loaded(), "byte %u corrupted: status %u", a, st.status());
      ++corrupt_checked;
    }
    const uint16_t hdr1 = uint16_t(hdr + est::layout::kSlotHeaderLen);
    const uint16_t b0 = uint16_t(est::ModelStore::kAreaBase + est::ModelStore::kAreaLen - B.len);
    for (uint16_t a = hdr1; a < est::ModelStore::kAreaBase + est::ModelStore::kAreaLen; ++a) {
      if (a >= hdr1 + est::layout::kSlotHeaderLen && a < b0) continue;
      FakeEeprom ee = both;
      ee.mem[a] ^= 0x10;
      est::Estimator e;
      est::ModelStore st(ee, e);
      st.boot();
      CHECK_MSG(st.status() == 1 && st.crc() == A.crc() && runs_like(e, A), "byte %u of B corrupted: A must run", a);
      ++corrupt_checked;
    }
  }
  // Reset at every write of a flash, clean and torn: B over A (slot 1 free), then A over
  // {A older, B running} (slot 0 reused).
  struct Case {
    const FakeEeprom* start;
    const Blob* old_b;
    const Blob* new_b;
  } cases[2] = {{&base, &A, &B}, {&both, &B, &A}};
  int old_seen = 0, new_seen = 0;
  long positions = 0;
  for (const Case& cs : cases) {
    long total = 0;
    {
      FakeEeprom ee = *cs.start;
      est::Estimator e;
      est::ModelStore st(ee, e);
      ee.writes = 0;
      st.boot();
      CHECK_MSG(flash(st, *cs.new_b), "clean flash");
      total = ee.writes;
    }
    positions += total + 1;
    for (int torn = 0; torn < 2; ++torn) {
      for (long k = 0; k <= total; ++k) {
        FakeEeprom ee = *cs.start;
        ee.writes = 0;
        ee.budget = k;
        ee.torn = torn;
        {
          est::Estimator e;
          est::ModelStore st(ee, e);
          st.boot();
          flash(st, *cs.new_b);
        }
        est::Estimator e;
        est::ModelStore st(ee, e);
        st.boot();
        bool is_new = st.status() == 1 && st.crc() == cs.new_b->crc();
        bool is_old = st.status() == 1 && st.crc() == cs.old_b->crc();
        CHECK_MSG(is_old || is_new, "reset at write %ld (torn %d): status %u, not the old model", k, torn, st.status());
        CHECK_MSG(!is_new || k >= total, "reset at write %ld: new model valid before the last write", k);
        CHECK_MSG(runs_like(e, is_new ? *cs.new_b : *cs.old_b), "reset at write %ld: model runs differently", k);
        old_seen += is_old;
        new_seen += is_new;
      }
    }
  }
  CHECK_MSG(new_seen >= 2 && old_seen >= 2, "torn-write outcomes old %d new %d", old_seen, new_seen);
  // The commit counter wraps: 300 alternating flashes, the last one always runs after a reboot.
  {
    FakeEeprom ee;
    est::Estimator e;
    est::ModelStore st(ee, e);
    st.boot();
    bool ok = true;
    for (int i = 0; i < 300 && ok; ++i) {
      const Blob& b = (i & 1) ? B : A;
      ok = flash(st, b);
      est::Estimator e2;
      est::ModelStore st2(ee, e2);
      st2.boot();
      ok = ok && st2.crc() == b.crc();
    }
    CHECK_MSG(ok, "commit counter wrap: the newest model did not run");
  }
  printf(
      "model store: %d corrupted bytes refused or fallen back; resets at %ld write positions x2 "
      "(clean/torn): old model %d, new model %d, no model 0, broken 0\n",
      corrupt_checked, positions, old_seen, new_seen);
  return g_failures ? 1 : 0;
}
