// The flash model store beside the EEPROM one: boot selection of the valid slot with the latest
// commit counter across both stores; a flash slot with a bad CRC, a bad header or a torn upload
// (only its first pages written) is skipped for the previous model; EEPROM newer than flash and
// back; MODEL_INFO names the running slot. Slot images are built as the host builds them: blob
// from the slot's first byte, 0xFF fill, the EEPROM store's slot header in the last 8 bytes.
#include "check.h"
#include <stdio.h>
#include <string.h>

#include "estimator.h"
#include "frame_codec.h"
#include "model_store.h"

namespace {

namespace L = est::layout;
namespace res = proto::result;
constexpr uint16_t kStore = L::kFlashSlots * L::kFlashSlotSize;

class Eeprom : public est::Eeprom {
 public:
  uint8_t mem[1024];
  Eeprom() { memset(mem, 0xFF, sizeof(mem)); }
  uint8_t read(uint16_t a) override { return a < 1024 ? mem[a] : 0xFF; }
  void write(uint16_t a, uint8_t v) override {
    if (a < 1024) mem[a] = v;
  }
};

class Flash : public est::FlashRom {
 public:
  uint8_t mem[kStore];
  Flash() { memset(mem, 0xFF, sizeof(mem)); }
  void read_block(uint16_t a, uint8_t* dst, uint8_t n) override {
    for (uint8_t i = 0; i < n; ++i) dst[i] = uint16_t(a + i) < kStore ? mem[a + i] : 0xFF;
  }
};

struct Blob {
  uint8_t data[L::kMaxBlobLength];
  uint16_t len;
  int16_t u[64][3], e[64][3];
  uint16_t crc() const { return uint16_t(data[len - 2] | data[len - 1] << 8); }
};

// Distinct blobs of the estimator vectors (real quantizer output) with their reference rows.
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
    if (len <= L::kMaxBlobLength / 2 && n >= 64) {
      memcpy(bl.data, buf, len);
      bl.len = uint16_t(len);
      ++got;
    }
  }
  fclose(fh);
  return got;
}

// The 1,024 bytes of one flash slot holding `b` with commit counter `seq`.
void slot_image(const Blob& b, uint8_t seq, uint8_t* img) {
  memset(img, 0xFF, L::kFlashSlotSize);
  memcpy(img, b.data, b.len);
  uint8_t* h = img + L::kFlashBlobMax;
  h[L::kOffSlotMagic] = L::kSlotMagic;
  h[L::kOffSlotSeq] = seq;
  h[L::kOffSlotLength] = uint8_t(b.len), h[L::kOffSlotLength + 1] = uint8_t(b.len >> 8);
  h[L::kOffSlotCrc] = uint8_t(b.crc()), h[L::kOffSlotCrc + 1] = uint8_t(b.crc() >> 8);
  uint16_t hc = proto::crc16(h, L::kOffSlotHeaderCrc);
  h[L::kOffSlotHeaderCrc] = uint8_t(hc), h[L::kOffSlotHeaderCrc + 1] = uint8_t(hc >> 8);
}

// An upload of `b` into flash slot `slot` (0, 1) that writes only its first `pages` pages.
void upload(Flash& f, int slot, const Blob& b, uint8_t seq, int pages = L::kFlashSlotSize / L::kFlashPage) {
  static uint8_t img[L::kFlashSlotSize];
  slot_image(b, seq, img);
  memcpy(f.mem + slot * L::kFlashSlotSize, img, size_t(pages) * L::kFlashPage);
}

bool flash_eeprom(est::ModelStore& st, const Blob& b) {
  int16_t d;
  if (st.begin(b.len, b.crc(), L::kFormatVersion, &d) != res::OK) return false;
  for (uint16_t off = 0; off < b.len; off = uint16_t(off + 112)) {
    uint8_t n = uint8_t(b.len - off > 112 ? 112 : b.len - off);
    if (st.chunk(off, b.data + off, n, &d) != res::OK) return false;
  }
  return st.commit(&d) == res::OK;
}

bool runs_like(est::Estimator& e, const Blob& b) {
  if (!e.loaded()) return false;
  e.reset();
  for (int t = 0; t < 64; ++t) {
    int16_t out[3];
    e.step(b.u[t], out);
    if (memcmp(out, b.e[t], sizeof(out)) != 0) return false;
  }
  return true;
}

// Boots a store over (ee, fl) and returns the running slot (kNoSlot when none); *crc its blob's.
uint8_t boot(Eeprom& ee, Flash& fl, uint16_t* crc = 0, const Blob* expect = 0, uint8_t* seq = 0) {
  est::Estimator e;
  est::ModelStore st(ee, e, &fl);
  st.boot();
  if (crc) *crc = st.crc();
  if (seq) *seq = st.seq();
  if (expect) CHECK_MSG(runs_like(e, *expect), "slot %u runs unlike its blob", st.active_slot());
  return st.active_slot();
}

}  // namespace

int main() {
  static Blob blobs[3];
  if (load_blobs(blobs, 3) < 3) {
    printf("FAIL need three blobs in data/estimator_vectors.txt\n");
    return 1;
  }
  const Blob &A = blobs[0], &B = blobs[1], &C = blobs[2];
  CHECK_MSG(A.crc() != B.crc() && B.crc() != C.crc() && A.crc() != C.crc(), "test blobs must differ");
  const uint8_t F0 = est::ModelStore::kFlashSlot0, F1 = uint8_t(F0 + 1), NONE = est::ModelStore::kNoSlot;

  // One flash slot alone runs, bit-exact, and MODEL_INFO names it.
  {
    Eeprom ee;
    Flash fl;
    upload(fl, 0, A, 5);
    est::Estimator e;
    est::ModelStore st(ee, e, &fl);
    st.boot();
    CHECK_MSG(st.status() == 1 && st.active_slot() == F0 && runs_like(e, A), "flash slot 0 alone: slot %u",
              st.active_slot());
    proto::ModelInfoReply info;
    st.info(&info);
    CHECK_MSG(info.slot == F0 && info.seq == 5 && info.crc == A.crc() && info.length == A.len,
              "MODEL_INFO slot %u seq %u", info.slot, info.seq);
    uint8_t buf[16];
    CHECK_MSG(st.read(0, 16, buf) == res::OK && memcmp(buf, A.data, 16) == 0, "MODEL_READ from flash");
    // An image that ends exactly at the store's base leaves the store in use.
    est::Estimator e_at_base;
    est::ModelStore at_base(ee, e_at_base, &fl);
    at_base.set_image_end(L::kFlashBase);
    at_base.boot();
    CHECK_MSG(at_base.flash_usable() && at_base.active_slot() == F0, "image ending at the store's base: slot %u",
              at_base.active_slot());
    CHECK_MSG(st.room() == L::kAreaLen, "EEPROM room beside a flash model: %u", st.room());
    // Without a flash store the same EEPROM holds nothing.
    est::Estimator e2;
    est::ModelStore st2(ee, e2);
    st2.boot();
    CHECK_MSG(st2.status() == 0 && !e2.loaded(), "no flash store: no model");
  }

  // A firmware image that reaches into the store (a build over its budget): its code would be
  // read as slot bytes, so the store is ignored (HELLO then lacks the FLASH_STORE capability).
  {
    Eeprom ee;
    Flash fl;
    upload(fl, 0, A, 5);
    est::Estimator e;
    est::ModelStore st(ee, e, &fl);
    st.set_image_end(uint16_t(L::kFlashBase + 1));
    st.boot();
    CHECK_MSG(!st.flash_usable() && st.active_slot() == NONE && !e.loaded(),
              "overlapping image: store ignored (slot %u)", st.active_slot());
    CHECK_MSG(flash_eeprom(st, B) && st.active_slot() == 0 && runs_like(e, B), "EEPROM store still works");
  }
  // Counter ordering: the later of two flash slots runs, modulo 256.
  {
    const uint8_t pairs[][2] = {{5, 6}, {6, 5}, {255, 0}, {0, 255}, {100, 227}, {200, 71}};
    for (const auto& p : pairs) {
      Eeprom ee;
      Flash fl;
      upload(fl, 0, A, p[0]);
      upload(fl, 1, B, p[1]);
      const bool second = int8_t(uint8_t(p[1] - p[0])) > 0;
      uint8_t seq;
      uint8_t s = boot(ee, fl, 0, second ? &B : &A, &seq);
      CHECK_MSG(s == (second ? F1 : F0) && seq == (second ? p[1] : p[0]), "seqs %u, %u: slot %u runs", p[0], p[1], s);
    }
  }
  // A bad flash slot is skipped for the previous one: blob byte, CRC trailer, header byte, magic.
  {
    const int hdr = L::kFlashSlotSize + L::kFlashBlobMax;
    const int spots[] = {L::kFlashSlotSize + 0,      L::kFlashSlotSize + 40,  L::kFlashSlotSize + B.len - 1,
                         hdr + L::kOffSlotSeq,       hdr + L::kOffSlotLength, hdr + L::kOffSlotCrc,
                         hdr + L::kOffSlotHeaderCrc, hdr + L::kOffSlotMagic};
    for (int at : spots) {
      Eeprom ee;
      Flash fl;
      upload(fl, 0, A, 5);
      upload(fl, 1, B, 6);
      fl.mem[at] ^= 0x5A;
      uint16_t crc;
      uint8_t s = boot(ee, fl, &crc, &A);
      CHECK_MSG(s == F0 && crc == A.crc(), "byte %d of the newer slot corrupted: slot %u runs", at, s);
    }
    // Both bad: nothing runs, and the status says a model was there.
    Eeprom ee;
    Flash fl;
    upload(fl, 0, A, 5);
    upload(fl, 1, B, 6);
    fl.mem[10] ^= 1;
    fl.mem[L::kFlashSlotSize + 10] ^= 1;
    est::Estimator e;
    est::ModelStore st(ee, e, &fl);
    st.boot();
    CHECK_MSG(st.status() == 2 && !e.loaded() && st.active_slot() == NONE, "both flash slots bad: status %u",
              st.status());
  }
  // Torn upload: the new model's image over slot 1 (which held an older model C) cut after each
  // page. The previous model (A in slot 0) runs until the last page, with the header, is written.
  {
    const int pages = L::kFlashSlotSize / L::kFlashPage;
    int old_runs = 0, new_runs = 0, none = 0;
    for (int k = 0; k <= pages; ++k) {
      Eeprom ee;
      Flash fl;
      upload(fl, 1, C, 4);
      upload(fl, 0, A, 5);
      upload(fl, 1, B, 6, k);
      uint16_t crc;
      uint8_t s = boot(ee, fl, &crc);
      if (s == F0 && crc == A.crc())
        ++old_runs;
      else if (s == F1 && crc == B.crc())
        ++new_runs;
      else
        ++none;
      CHECK_MSG(k == pages ? s == F1 : s == F0, "upload torn after %d of %d pages: slot %u runs", k, pages, s);
    }
    CHECK_MSG(old_runs == pages && new_runs == 1 && none == 0, "torn uploads: old %d new %d other %d", old_runs,
              new_runs, none);
    // The same with the previous model in the EEPROM (flash store empty before the upload).
    for (int k = 0; k <= pages; ++k) {
      Eeprom ee;
      Flash fl;
      {
        est::Estimator e;
        est::ModelStore st(ee, e, &fl);
        st.boot();
        CHECK_MSG(flash_eeprom(st, A), "EEPROM flash");
      }
      upload(fl, 0, B, 1, k);
      uint8_t s = boot(ee, fl);
      CHECK_MSG(k == pages ? s == F0 : s == 0, "upload over an EEPROM model torn after %d pages: slot %u", k, s);
    }
  }
  // EEPROM newer than flash and back: each store's write takes the latest counter + 1.
  {
    Eeprom ee;
    Flash fl;
    upload(fl, 0, A, 5);
    uint8_t seq;
    CHECK_MSG(boot(ee, fl) == F0, "flash A runs");
    {
      est::Estimator e;
      est::ModelStore st(ee, e, &fl);
      st.boot();
      CHECK_MSG(flash_eeprom(st, B) && st.active_slot() == 0 && st.seq() == 6 && runs_like(e, B),
                "EEPROM write over a flash model: slot %u seq %u", st.active_slot(), st.seq());
    }
    CHECK_MSG(boot(ee, fl, 0, &B, &seq) == 0 && seq == 6, "EEPROM newer than flash runs after reboot (seq %u)", seq);
    upload(fl, 1, C, uint8_t(seq + 1));  // the host's upload: latest + 1 into the flash slot not running
    CHECK_MSG(boot(ee, fl, 0, &C, &seq) == F1 && seq == 7, "flash newer than EEPROM runs (seq %u)", seq);
    {
      est::Estimator e;
      est::ModelStore st(ee, e, &fl);
      st.boot();
      // The EEPROM slot written is 0 again: with a flash model running, BEGIN takes slot 0.
      CHECK_MSG(flash_eeprom(st, A) && st.active_slot() == 0 && st.seq() == 8, "EEPROM again: slot %u seq %u",
                st.active_slot(), st.seq());
    }
    CHECK_MSG(boot(ee, fl, 0, &A, &seq) == 0 && seq == 8, "EEPROM newer again (seq %u)", seq);
    // The newest EEPROM slot corrupted: the latest valid of the other three runs (flash C, 7).
    ee.mem[L::kAreaBase + 3] ^= 0x10;
    CHECK_MSG(boot(ee, fl, 0, &C, &seq) == F1 && seq == 7, "corrupt newest EEPROM slot: flash seq %u runs", seq);
    // MODEL_ERASE clears the EEPROM slots only; the flash model is back at the next boot.
    {
      est::Estimator e;
      est::ModelStore st(ee, e, &fl);
      st.boot();
      CHECK_MSG(st.erase() == res::OK && !e.loaded(), "erase");
    }
    CHECK_MSG(boot(ee, fl, 0, &C) == F1, "flash model after an erase and a reboot");
  }
  printf("%s: %d checks, %d failures\n", __FILE__, g_checks, g_failures);
  return g_failures ? 1 : 0;
}
