#include "lrf/core/cpu_features.h"

#include <cstdint>
#include <cstdlib>
#include <algorithm>
#include <initializer_list>
#include <string>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

#include "lrf/core/error.h"

namespace lrf {
namespace {

struct Bf16Support {
  bool avx512 = false;  // AVX512_BF16 with AVX-512 F/BW/VL/DQ, all saved by the OS
  bool amx = false;     // AMX-BF16, saved by the OS
};

#if defined(__x86_64__) || defined(__i386__)
// XCR0: the register state the OS saves on a context switch. The instructions fault (or their
// registers get clobbered) unless the OS enabled the state they use.
uint64_t xcr0() {
  uint32_t eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (!__get_cpuid(1, &eax, &ebx, &ecx, &edx) || !(ecx & (1u << 27))) return 0;  // no OSXSAVE
  uint32_t lo = 0, hi = 0;
  __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));  // inline: no -mxsave for this file
  return (static_cast<uint64_t>(hi) << 32) | lo;
}

Bf16Support detect() {
  Bf16Support found;
  uint32_t eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (!__get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx)) return found;
  const uint32_t max_subleaf = eax;
  const uint64_t os = xcr0();
  // AVX-512 state: SSE, AVX, opmask, ZMM upper halves, ZMM16-31 (bits 1, 2, 5, 6, 7).
  const bool os_avx512 = (os & 0xE6) == 0xE6;
  // AMX state: TILECFG and TILEDATA (bits 17, 18). Linux also wants a per-process permission request,
  // which oneDNN makes itself before using the tiles.
  const bool os_amx = (os & 0x60000) == 0x60000;
  const bool avx512_core = (ebx & (1u << 16)) && (ebx & (1u << 17)) && (ebx & (1u << 30)) && (ebx & (1u << 31));
  const bool amx_bf16 = (edx & (1u << 22)) != 0;
  found.amx = amx_bf16 && os_amx && avx512_core && os_avx512;
  if (max_subleaf < 1 || !avx512_core || !os_avx512) return found;
  if (!__get_cpuid_count(7, 1, &eax, &ebx, &ecx, &edx)) return found;
  found.avx512 = (eax & (1u << 5)) != 0;  // AVX512_BF16
  return found;
}
#else
Bf16Support detect() { return {}; }
#endif

const Bf16Support& support() {
  static const Bf16Support found = detect();
  return found;
}

}  // namespace

bool cpu_reports_bf16() { return support().avx512 || support().amx; }

bool cpu_has_bf16() {
  if (const char* env = std::getenv("LRF_CPU_BF16"); env && *env) {
    const std::string v = env;
    if (v == "0") return false;
    if (v == "1") return true;
    fail("LRF_CPU_BF16 must be 0 or 1, got '" + v + "'");
  }
  return cpu_reports_bf16();
}

bool cpu_has_avx512_bf16() { return cpu_has_bf16() && support().avx512; }

namespace {

bool switched_off(const char* name) {
  const char* v = std::getenv(name);
  return v && std::string(v) == "0";
}

// The tile side $NAME asks for, `fallback` when unset; anything not `allowed` is refused.
int tile_from_env(const char* name, int fallback, std::initializer_list<int> allowed) {
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  const std::string tile = v;
  std::string choices;
  for (int a : allowed) {
    if (tile == std::to_string(a)) return a;
    choices += (choices.empty() ? "" : " or ") + std::to_string(a);
  }
  fail(std::string(name) + " must be " + choices + ", got '" + tile + "'");
}

}  // namespace

bool fused_conv_enabled() { return !switched_off("LRF_FUSED_CONV"); }

bool winograd_enabled() { return fused_conv_enabled() && !switched_off("LRF_WINOGRAD") && cpu_has_avx512_bf16(); }

int winograd_tile() { return tile_from_env("LRF_WINOGRAD_TILE", 3, {2, 3}); }

SimdLevel cpu_simd_level() {
#if defined(__x86_64__) || defined(__i386__)
  static const SimdLevel level = [] {
    __builtin_cpu_init();
    uint32_t eax = 0, ebx = 0, ecx = 0, edx = 0;
    const uint64_t os = xcr0();
    const bool os_avx = (os & 0x6) == 0x6, os_avx512 = (os & 0xE6) == 0xE6;
    if (!os_avx || !__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return SimdLevel::baseline;
    if (__get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx) && (ebx & (1u << 16)) && os_avx512) return SimdLevel::avx512;
    return SimdLevel::avx2;
  }();
  return level;
#else
  return SimdLevel::baseline;
#endif
}

const char* simd_level_name(SimdLevel level) {
  switch (level) {
    case SimdLevel::avx512: return "avx512";
    case SimdLevel::avx2: return "avx2";
    default: return "baseline";
  }
}

namespace {

// $LRF_CPU_ISA as a level; the CPU's own when unset.
SimdLevel isa_cap() {
  const char* env = std::getenv("LRF_CPU_ISA");
  if (!env || !*env) return cpu_simd_level();
  const std::string v = env;
  if (v == "avx512") return SimdLevel::avx512;
  if (v == "avx2") return SimdLevel::avx2;
  if (v == "baseline") return SimdLevel::baseline;
  fail("LRF_CPU_ISA must be avx512, avx2 or baseline, got '" + v + "'");
}

}  // namespace

SimdLevel simd_level() { return std::min(cpu_simd_level(), isa_cap()); }

void apply_isa_cap_to_onednn() {
  const char* env = std::getenv("LRF_CPU_ISA");
  if (!env || !*env || std::getenv("ONEDNN_MAX_CPU_ISA") || std::getenv("DNNL_MAX_CPU_ISA")) return;
  const SimdLevel cap = isa_cap();
  const char* onednn = cap == SimdLevel::avx512 ? (cpu_has_bf16() ? "ALL" : "AVX512_CORE_VNNI")
                       : cap == SimdLevel::avx2 ? "AVX2"
                                                : "SSE41";
  ::setenv("ONEDNN_MAX_CPU_ISA", onednn, 0);
}

bool cpu_has_avx2() { return simd_level() >= SimdLevel::avx2; }

int winograd_f32_tile() { return tile_from_env("LRF_WINOGRAD_F32_TILE", 4, {2, 4, 6}); }

bool winograd_f32_enabled() {
  return fused_conv_enabled() && !switched_off("LRF_WINOGRAD") && simd_level() >= SimdLevel::avx2;
}

}  // namespace lrf
