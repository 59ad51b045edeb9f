#pragma once
// What the CPU can run, asked at run time (the build targets baseline x86-64), and the environment
// switches that keep the project's own kernels from using it.
namespace lrf {

// Whether the CPU multiplies bf16 matrices natively, which is what makes bf16 convolutions fast in
// oneDNN: AVX512_BF16 (with AVX-512 F/BW/VL/DQ, Cooper Lake, Zen 4 and later) or AMX-BF16 (Sapphire
// Rapids and later), in both cases with the OS saving the registers. Without them oneDNN emulates bf16
// (AVX-512 only) or libtorch falls back to slow reference kernels, both slower than fp32.
// $LRF_CPU_BF16=0 or =1 overrides the answer (tests simulate a CPU without BF16 with it).
bool cpu_has_bf16();

// The same answer from the CPU alone, ignoring $LRF_CPU_BF16 (for logs).
bool cpu_reports_bf16();

// Whether the CPU has the AVX512_BF16 instructions themselves (the dot products of bf16 pairs that the
// project's own bf16 kernels use), and cpu_has_bf16() is not overridden to false.
bool cpu_has_avx512_bf16();

// Whether the autoencoders' inference may run its fused convolutions (onednn_conv.h): yes unless
// $LRF_FUSED_CONV=0 (kept to compare against libtorch's path, and as a way out should a oneDNN build
// misbehave). Read on every call, so that a test can switch it.
bool fused_conv_enabled();

// Whether bf16 inference and training may run 3x3 convolutions as Winograd's (winograd_conv.h,
// winograd_training.h): cpu_has_avx512_bf16(), fused_conv_enabled() (which switches all of the project's
// own convolution kernels), and $LRF_WINOGRAD is not 0. Read on every call.
bool winograd_enabled();

// The output tile side of Winograd's convolutions (inference, and training's forward and input
// gradient; the weight gradient has 2x2 tiles either way): 3, F(3x3, 3x3), unless $LRF_WINOGRAD_TILE is
// 2, F(2x2, 3x3) (kept to compare against). Read on every call; inference layers keep the tiles they
// were built with.
int winograd_tile();

// The widest float vectors the project's own kernels may use: AVX-512F (16 lanes, with the OS saving its
// state), AVX2 with FMA (8 lanes), or neither (baseline x86-64). What the CPU has, capped by
// $LRF_CPU_ISA (avx512, avx2 or baseline), so that one machine can run, test and time each path; lrf's
// start-up passes the same cap to oneDNN (apply_isa_cap_to_onednn). Read on every call.
enum class SimdLevel { baseline = 0, avx2 = 1, avx512 = 2 };
SimdLevel simd_level();
// The CPU's own, ignoring $LRF_CPU_ISA.
SimdLevel cpu_simd_level();
const char* simd_level_name(SimdLevel level);
// Sets ONEDNN_MAX_CPU_ISA from $LRF_CPU_ISA (avx512: no cap, or AVX512_CORE_VNNI when $LRF_CPU_BF16=0;
// avx2: AVX2; baseline: SSE41) unless the user set oneDNN's own variable. Must run before oneDNN's first
// primitive, which reads it once.
void apply_isa_cap_to_onednn();

// Whether the CPU runs AVX2 (8-lane float vectors), for the loops compiled for it beside the baseline
// ones: the rasterizer's kernels and Adam's update: simd_level() >= avx2.
bool cpu_has_avx2();

// Whether float32 3x3 convolutions may run as the project's Winograd kernels (winograd_f32.h): a SIMD
// level of AVX2 or more, fused_conv_enabled(), and $LRF_WINOGRAD is not 0. Read on every call.
bool winograd_f32_enabled();

// The output tile side of the float32 Winograd kernels: 4, F(4x4, 3x3), unless $LRF_WINOGRAD_F32_TILE is 2,
// F(2x2, 3x3), or 6, F(6x6, 3x3) (kept to compare against: docs/speed.md). Read on every call.
int winograd_f32_tile();

}  // namespace lrf
