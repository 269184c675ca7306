// harness.cpp — the co-simulation harness: replays a cycle stream from shellsim through the
// Verilated `cosim_top` and compares, every cycle, the handshake and every valid stage
// register with the model's values. Generic over the unit: the stream's shape comes from
// cosim_shape.h, written by `shellsim cosim` from src/rtl/layout.rs.
//
// Stream (little-endian u32 words on stdin), one record per cycle:
//   flags: bit0 in_valid, bit1 out_ready, bit2 expected in_ready, bit3 expected fire
//          (out_valid && out_ready), bit4 a new job follows; 0xFFFFFFFF ends the stream.
//   a new job: tag, IN_WORDS of in_bus, ST_WORDS of the job's expected stage registers.
//   an expected fire: the tag that leaves.
//   bit5 (side-by-side waveform builds): the model ICU's stages this cycle — a valid mask,
//          S ray ids, S patch ids, t of the result stage (2 words) — driven onto m_*.
// Output: "OK cycles=C jobs=J" (exit 0), or one "MISMATCH ..." line (exit 1); a malformed
// stream is exit 2.

#include "Vcosim_top.h"
#include "cosim_shape.h"
#include "verilated.h"
#if COSIM_TRACE
#include "verilated_fst_c.h"
#endif
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

// Words of a signal of W bits as Verilator holds it.
void put(CData& d, const uint32_t* w) { d = static_cast<CData>(w[0]); }
void put(SData& d, const uint32_t* w) { d = static_cast<SData>(w[0]); }
void put(IData& d, const uint32_t* w) { d = w[0]; }
void put(QData& d, const uint32_t* w) { d = w[0] | (static_cast<QData>(w[1]) << 32); }
template <std::size_t N> void put(VlWide<N>& d, const uint32_t* w) {
  for (std::size_t i = 0; i < N; i++) d[i] = w[i];
}
void get(const CData& d, uint32_t* w) { w[0] = d; }
void get(const SData& d, uint32_t* w) { w[0] = d; }
void get(const IData& d, uint32_t* w) { w[0] = d; }
void get(const QData& d, uint32_t* w) {
  w[0] = static_cast<uint32_t>(d);
  w[1] = static_cast<uint32_t>(d >> 32);
}
template <std::size_t N> void get(const VlWide<N>& d, uint32_t* w) {
  for (std::size_t i = 0; i < N; i++) w[i] = d[i];
}

bool bit(const uint32_t* w, uint32_t i) { return (w[i / 32] >> (i % 32)) & 1; }

// `n` ≤ 32 bits of w from bit `at`.
uint32_t bits32(const uint32_t* w, uint32_t at, uint32_t n) {
  uint32_t i = at / 32, s = at % 32;
  uint64_t x = w[i] >> s;
  if (s != 0 && s + n > 32) x |= static_cast<uint64_t>(w[i + 1]) << (32 - s);
  return n == 32 ? static_cast<uint32_t>(x) : static_cast<uint32_t>(x) & ((1u << n) - 1);
}

// Compares `width` bits at `off` of a and b, 32 at a time.
bool same(const uint32_t* a, const uint32_t* b, uint32_t off, uint32_t width) {
  for (uint32_t i = 0; i < width; i += 32) {
    uint32_t n = width - i < 32 ? width - i : 32;
    if (bits32(a, off + i, n) != bits32(b, off + i, n)) return false;
  }
  return true;
}

// `width` bits at `off` as hex, most significant first.
void hex(FILE* f, const uint32_t* w, uint32_t off, uint32_t width) {
  uint32_t digits = (width + 3) / 4;
  for (uint32_t d = digits; d-- > 0;) {
    unsigned v = 0;
    for (uint32_t b = 0; b < 4; b++) {
      uint32_t i = d * 4 + b;
      if (i < width && bit(w, off + i)) v |= 1u << b;
    }
    std::fputc("0123456789abcdef"[v], f);
  }
}

bool read_words(uint32_t* w, std::size_t n) {
  return std::fread(w, sizeof(uint32_t), n, stdin) == n;
}

const std::size_t RING = 1u << 14;  // jobs in flight are far fewer

}  // namespace

int main(int argc, char** argv) {
  Verilated::commandArgs(argc, argv);
  const char* trace_path = nullptr;
  for (int i = 1; i + 1 < argc; i++)
    if (std::strcmp(argv[i], "--fst") == 0) trace_path = argv[i + 1];
  Vcosim_top top;
#if COSIM_TRACE
  Verilated::traceEverOn(true);
  VerilatedFstC tfp;
  if (trace_path) {
    top.trace(&tfp, 99);
    tfp.open(trace_path);
  }
#else
  if (trace_path) {
    std::fprintf(stderr, "this harness was built without --trace-fst\n");
    return 2;
  }
#endif
  uint64_t time = 0;
  auto dump = [&]() {
#if COSIM_TRACE
    if (trace_path) tfp.dump(time);
#endif
    time += 10;
  };
  // One sample per cycle, before its edge (time 10·cycle): the registers and the model's
  // values of the same cycle side by side.
  auto edge = [&]() {
    top.clk = 1;
    top.eval();
    top.clk = 0;
    top.eval();
  };
  top.clk = 0;
  top.rst = 1;
  top.in_valid = 0;
  top.out_ready = 0;
  top.eval();
  edge();
  edge();
  top.rst = 0;

  std::vector<uint32_t> expected(RING * ST_WORDS + 4, 0);
  std::vector<uint32_t> in(IN_WORDS + 2, 0), st(ST_WORDS + 4, 0), tags(S + 2, 0);
  std::vector<uint32_t> valid((S + 31) / 32 + 2, 0);
  uint32_t in_tag = 0;
  uint64_t cycle = 0, jobs = 0;
  for (;; cycle++) {
    uint32_t flags;
    if (!read_words(&flags, 1)) {
      std::fprintf(stderr, "stream ended without its end mark at cycle %llu\n",
                   static_cast<unsigned long long>(cycle));
      return 2;
    }
    if (flags == 0xFFFFFFFFu) break;
    if (flags & 16) {
      if (!read_words(&in_tag, 1) || !read_words(in.data(), IN_WORDS) ||
          !read_words(&expected[(in_tag % RING) * ST_WORDS], ST_WORDS)) {
        std::fprintf(stderr, "stream ended inside a job at cycle %llu\n",
                     static_cast<unsigned long long>(cycle));
        return 2;
      }
      put(top.in_bus, in.data());
      top.in_tag = in_tag;
      jobs++;
    }
    uint32_t fire_tag = 0;
    if ((flags & 8) && !read_words(&fire_tag, 1)) return 2;
#if COSIM_MODEL
    if (flags & 32) {
      uint32_t snap[1 + 2 * S + 2];
      if (!read_words(snap, 1 + 2 * S + 2)) return 2;
      top.m_valid = snap[0];
      put(top.m_ray, snap + 1);
      put(top.m_patch, snap + 1 + S);
      put(top.m_t, snap + 1 + 2 * S);
    }
#else
    if (flags & 32) {
      std::fprintf(stderr, "a model snapshot in the stream, but this harness shows none\n");
      return 2;
    }
#endif
    top.in_valid = flags & 1;
    top.out_ready = (flags >> 1) & 1;
    top.eval();
    dump();
    const unsigned long long c = cycle;
    if (static_cast<bool>(top.in_ready) != static_cast<bool>(flags & 4)) {
      std::printf("MISMATCH kind=in_ready cycle=%llu rtl=%d model=%d\n", c, int(top.in_ready),
                  int((flags >> 2) & 1));
      return 1;
    }
    bool fire = top.out_valid && top.out_ready;
    if (fire != static_cast<bool>(flags & 8) || (fire && top.out_tag != fire_tag)) {
      std::printf("MISMATCH kind=out cycle=%llu rtl_fire=%d rtl_tag=%u model_fire=%d model_tag=%u\n",
                  c, int(fire), unsigned(top.out_tag), int((flags >> 3) & 1), fire_tag);
      return 1;
    }
    get(top.st_valid, valid.data());
    get(top.st_tag, tags.data());
    get(top.st_bus, st.data());
    for (uint32_t k = 0; k < S; k++) {
      if (!bit(valid.data(), k)) continue;
      uint32_t tag = tags[k];
      const uint32_t* want = &expected[(tag % RING) * ST_WORDS];
      if (!same(st.data(), want, STAGE_OFF[k], STAGE_W[k])) {
        std::printf("MISMATCH kind=stage cycle=%llu stage=%u tag=%u rtl=", c, k, tag);
        hex(stdout, st.data(), STAGE_OFF[k], STAGE_W[k]);
        std::printf(" model=");
        hex(stdout, want, STAGE_OFF[k], STAGE_W[k]);
        std::printf("\n");
        return 1;
      }
    }
    edge();
  }
#if COSIM_TRACE
  if (trace_path) tfp.close();
#endif
  std::printf("OK cycles=%llu jobs=%llu\n", static_cast<unsigned long long>(cycle),
              static_cast<unsigned long long>(jobs));
  return 0;
}
