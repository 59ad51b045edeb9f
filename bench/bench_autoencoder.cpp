// The autoencoders in fp32 against bf16 (Autoencoder::set_precision), measured back to back in one
// process: each repetition runs both precisions, in alternating order, so that the machine's drift
// (other jobs, clocks) falls on both alike; the speed-up is reported per repetition (median and range).
//
// Cases (all TAEF2 at 504x376, fern's images_8 size cropped to multiples of 8, batch 1, real weights
// from ../shared/models when present, else random weights of the same architecture):
//   conv      one 64->64 3x3 convolution at 504x376, channels-last: what oneDNN reaches per precision
//             (the ceiling for the networks, which are almost only such convolutions), and in float32
//             oneDNN's direct convolution against the float32 Winograd kernel, alternated, and (where
//             oneDNN builds it: AVX-512) oneDNN's own float32 Winograd against lrf's, in oneDNN's own
//             layouts and with the reorders from and to channels-last that lrf's layers would need
//   bounds    the least time of a decode, an encode, a Stage I and a Stage III step if every convolution
//             ran at the rate of the fastest bf16 64->64 convolution measured here (FLOPs / that rate):
//             inference's (Winograd where the CPU has AVX512_BF16) for decode and encode and for the
//             training steps' forward and data gradients, the faster weight gradient's (Winograd's or
//             the direct one's) for their weight gradients; then the floor under those: the products
//             alone (Winograd's for the convolutions it takes, with the tiles chosen, direct for the
//             rest), counted layer by layer, at the CPU's bf16 dot-product peak measured on registers;
//             and the float32 floors per vector width (AVX2, AVX-512F): the products with the float32
//             Winograd kernels and with direct convolutions, at that width's FMA peak on registers
//   wgrad     the weight and bias gradient of one 64->64 3x3 convolution on 4 crops of 96x96 (a Stage I
//             step's encoder level), bf16: oneDNN's direct one against Winograd's (where the CPU has
//             AVX512_BF16), alternated
//   tiles     bf16 decode and encode with Winograd's 2x2 output tiles (A) against its 3x3 ones (B, the
//             default), alternated: two copies of TAEF2 whose layers were built under each
//             $LRF_WINOGRAD_TILE (where the CPU has AVX512_BF16)
//   narrow    the decoder's last layer (64 -> 3 at 504x376, bf16): libtorch's convolution (oneDNN direct)
//             against NarrowConv3x3 (where the CPU has AVX512_BF16), alternated
//   encode    image -> latent, no gradient
//   decode    latent -> image, no gradient
//   fused     encode and decode, bf16 then fp32: the torch modules against the fused layers
//             (tiny_fused.h: residual adds and ReLUs done by the convolutions' stores), alternated
//   backward  decode_unclamped + backward to the latent (the decoder frozen): a refinement step's share
//   stage1    one Stage I step: 2 pairs of 192x192 crops of llff-fern, L_VAE + L_corres + L_reg,
//             backward into the encoder, Adam on float32 master weights
//   stage3    one Stage III step: 2 + 2 crops of 128x128 (latents of fern's views), L1 through the
//             decoder, backward into the decoder, Adam; then (stage3x3, fp32) the step's three terms of
//             2 crops each decoded apart against stacked into one pass, as lrf's Stage III runs them
//   quality   round-trip PSNR on fern's test views 0, 8, 16 per precision, and their difference
//   kl        the full-size KL-f8 VAE (random weights) encode and decode at 504x376
//   paths     every instruction-set path this CPU has, side by side (bf16 where native, float32 Winograd
//             on AVX-512F and on AVX2, float32 with oneDNN's direct convolutions: the path before it):
//             decode, encode, the refinement's decoder share (whole view, coarse layers adapted), a
//             Stage I and a Stage III step, each with its float32 floor
// GFLOP/s count the convolutions' multiply-adds (x2) from the architecture (see taef2_*_flops).
//
// usage: bench_autoencoder [--threads N] [--reps R] [CASE ...]   (default: every case but kl; 2 threads)
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <oneapi/dnnl/dnnl.hpp>
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/conv/bf16_vectors.h"
#include "lrf/autoencoder/conv/narrow_conv.h"
#include "lrf/autoencoder/conv/onednn_conv.h"
#include "lrf/autoencoder/conv/winograd_conv.h"
#include "lrf/autoencoder/conv/winograd_f32.h"
#include "lrf/autoencoder/conv/winograd_weight_gradient.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/core/allocator.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"
#include "lrf/core/threads.h"
#include "lrf/eval/metrics.h"
#include "lrf/optim/param_adam.h"
#include "lrf/finetune/encoder_finetune.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/finetune/stage3_terms.h"
#include "lrf/scene/scene.h"
#include "taef2_layers.h"

namespace {

using lrf::Precision;
constexpr int kWidth = 504, kHeight = 376;

std::string shared_dir() {
  const char* s = std::getenv("LRF_SHARED");
  return s && *s ? s : "../shared";
}

std::unique_ptr<lrf::Autoencoder> make_taef2() {
  try {
    return lrf::load_autoencoder("taef2");
  } catch (const lrf::Error& e) {
    std::fprintf(stderr, "bench: %s; using random TAEF2-shaped weights\n", e.what());
    auto ae = std::make_unique<lrf::TinyAutoencoder>(32, true);
    ae->set_channels_last(true);
    return ae;
  }
}

// Multiply-adds of TAEF2's convolutions (the rest is a few percent of the time), counted from its
// architecture (tiny_ae.h): 3x3 convs of 64 channels everywhere, a 1x1 64->256->64 pool branch in the
// three blocks at 1/8 resolution, a 3-channel image and a 32-channel latent.
using bench::kConv64;
using bench::kPool;
double taef2_encode_flops(int w, int h) {
  const double p = static_cast<double>(w) * h;
  const double full = (3.0 * 64 * 9 + 3 * kConv64) * p;                       // conv in, one block
  const double levels = 10 * kConv64 * (p / 4 + p / 16 + p / 64);               // stride-2 conv + 3 blocks each
  const double latent = (3 * kPool + 64.0 * 32 * 9) * (p / 64);                 // pool branches, conv out
  return 2 * (full + levels + latent);
}
double taef2_decode_flops(int w, int h) {
  const double p = static_cast<double>(w) * h, cells = p / 64;
  const double latent = (32.0 * 64 * 9 + 9 * kConv64 + 3 * kPool) * cells;     // conv in, 3 blocks
  const double middle = 10 * kConv64 * (cells * 4 + cells * 16);                // 3 blocks + upsampling conv
  const double full = (4 * kConv64 + 64.0 * 3 * 9) * p;                         // upsampling conv, block, conv out
  return 2 * (latent + middle + full);
}

// The multiply-adds the fused decode skips: each 2x upsampling's 3x3 convolution runs as 2x2 phases
// (UpsampledConv2d), 4/9 of its products, at 1/4, 1/2 and full resolution.
double taef2_upsampling_saving_flops(int w, int h) {
  const double p = static_cast<double>(w) * h, cells = p / 64;
  return 2 * (5.0 / 9) * kConv64 * (cells * 4 + cells * 16 + p);
}

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Runs `once(false)` (the A case) and `once(true)` (B) `reps` times each, alternating which goes first,
// after one warm-up each (oneDNN builds its kernels on first use). Prints seconds per call, calls per
// second, the speed-up of B over A per repetition (A's time / B's), and GFLOP/s when `flops` is given.
void alternate(const std::string& name, int reps, double flops, const char* a_name, const char* b_name,
               const std::function<void(bool)>& once) {
  once(false);
  once(true);
  std::vector<double> ta, tb, ratio;
  for (int r = 0; r < reps; ++r) {
    double a = 0, b = 0;
    for (int k = 0; k < 2; ++k) {
      const bool a_now = (k == 0) == (r % 2 == 0);
      const double t0 = now();
      once(!a_now);
      (a_now ? a : b) = now() - t0;
    }
    ta.push_back(a);
    tb.push_back(b);
    ratio.push_back(a / b);
  }
  auto row = [&](const char* label, const std::vector<double>& t) {
    const double m = median(t);
    std::printf("%-10s %-7s %8.1f ms [%7.1f - %7.1f]  %6.2f /s", name.c_str(), label, 1e3 * m,
                1e3 * *std::min_element(t.begin(), t.end()), 1e3 * *std::max_element(t.begin(), t.end()), 1 / m);
    if (flops > 0) std::printf("  %6.0f GFLOP/s", flops / m * 1e-9);
    std::printf("\n");
  };
  row(a_name, ta);
  row(b_name, tb);
  std::printf("%-10s speed-up %s over %s: %.2fx (per repetition %.2f - %.2f, %d repetitions)\n\n", name.c_str(), b_name,
              a_name, median(ratio), *std::min_element(ratio.begin(), ratio.end()),
              *std::max_element(ratio.begin(), ratio.end()), reps);
  std::fflush(stdout);
}

// fp32 (A) against bf16 (B).
void ab(const std::string& name, int reps, double flops, const std::function<void(Precision)>& once) {
  alternate(name, reps, flops, "fp32", "bf16", [&](bool bf16) { once(bf16 ? Precision::bf16 : Precision::fp32); });
}

at::Tensor fern_image(int index) {
  lrf::SceneOptions so;
  so.images_dir = "images_8";
  so.crop_to_multiple_of_8 = true;
  lrf::Scene scene = lrf::load_scene(shared_dir() + "/scenes/llff-fern", so);
  return lrf::image_to_batch(scene.load_image(index));
}

// oneDNN's float32 Winograd convolution (algorithm::convolution_winograd), for comparison with lrf's: the
// input, output and weights in the layouts oneDNN picks for it (reordered once, outside the timing: its best
// case, as a network kept in those layouts would see it). nullptr where oneDNN refuses the algorithm.
class OnednnWinograd {
 public:
  static std::unique_ptr<OnednnWinograd> create(const at::Tensor& x, const at::Tensor& w) {
    using dt = dnnl::memory::data_type;
    using tag = dnnl::memory::format_tag;
    auto self = std::make_unique<OnednnWinograd>();
    const dnnl::memory::dim n = x.size(0), c = x.size(1), h = x.size(2), wd = x.size(3), o = w.size(0);
    const dnnl::memory::desc src_any({n, c, h, wd}, dt::f32, tag::any), dst_any({n, o, h, wd}, dt::f32, tag::any),
        weights_any({o, c, 3, 3}, dt::f32, tag::any);
    try {
      using conv = dnnl::convolution_forward;
      const conv::desc desc(dnnl::prop_kind::forward_inference, dnnl::algorithm::convolution_winograd, src_any,
                            weights_any, dst_any, {1, 1}, {1, 1}, {1, 1});
      const conv::primitive_desc pd(desc, self->engine_);
      std::printf("conv-fp32  oneDNN's Winograd: %s\n", pd.impl_info_str());
      self->conv_ = conv(pd);
      self->src_ = dnnl::memory(pd.src_desc(), self->engine_);
      self->dst_ = dnnl::memory(pd.dst_desc(), self->engine_);
      self->weights_ = dnnl::memory(pd.weights_desc(), self->engine_);
      const at::Tensor x_plain = x.contiguous(), w_plain = w.contiguous();
      dnnl::memory x_mem({{n, c, h, wd}, dt::f32, tag::nchw}, self->engine_, x_plain.data_ptr());
      dnnl::memory w_mem({{o, c, 3, 3}, dt::f32, tag::oihw}, self->engine_, w_plain.data_ptr());
      dnnl::reorder(x_mem, self->src_).execute(self->stream_, x_mem, self->src_);
      dnnl::reorder(w_mem, self->weights_).execute(self->stream_, w_mem, self->weights_);
      self->stream_.wait();
    } catch (const dnnl::error& e) {
      std::printf("conv-fp32  oneDNN's Winograd: not built on this CPU (%s)\n\n", e.what());
      return nullptr;
    }
    return self;
  }
  void run() {
    conv_.execute(stream_, {{DNNL_ARG_SRC, src_}, {DNNL_ARG_WEIGHTS, weights_}, {DNNL_ARG_DST, dst_}});
    stream_.wait();
  }
  // As lrf's layers would call it: a channels-last input reordered into oneDNN's layout, convolved, and
  // the output reordered back to channels-last.
  void run_channels_last(const at::Tensor& x, at::Tensor& y) {
    using dt = dnnl::memory::data_type;
    using tag = dnnl::memory::format_tag;
    dnnl::memory x_mem({{x.size(0), x.size(1), x.size(2), x.size(3)}, dt::f32, tag::nhwc}, engine_, x.data_ptr());
    dnnl::memory y_mem({{y.size(0), y.size(1), y.size(2), y.size(3)}, dt::f32, tag::nhwc}, engine_, y.data_ptr());
    dnnl::reorder(x_mem, src_).execute(stream_, x_mem, src_);
    conv_.execute(stream_, {{DNNL_ARG_SRC, src_}, {DNNL_ARG_WEIGHTS, weights_}, {DNNL_ARG_DST, dst_}});
    dnnl::reorder(dst_, y_mem).execute(stream_, dst_, y_mem);
    stream_.wait();
  }

 private:
  dnnl::engine engine_{dnnl::engine::kind::cpu, 0};
  dnnl::stream stream_{engine_};
  dnnl::convolution_forward conv_;
  dnnl::memory src_, dst_, weights_;
};

void bench_conv(int reps) {
  torch::NoGradGuard no_grad;
  torch::manual_seed(0);
  at::Tensor x = torch::rand({1, 64, kHeight, kWidth}).contiguous(at::MemoryFormat::ChannelsLast);
  at::Tensor w = torch::randn({64, 64, 3, 3}).contiguous(at::MemoryFormat::ChannelsLast) * 0.05;
  at::Tensor x16 = x.to(at::kBFloat16), w16 = w.to(at::kBFloat16);
  const double flops = 2.0 * kConv64 * kWidth * kHeight;
  ab("conv", reps, flops, [&](Precision p) {
    at::Tensor y = p == Precision::bf16 ? at::conv2d(x16, w16, {}, 1, 1) : at::conv2d(x, w, {}, 1, 1);
  });
  if (lrf::WinogradF32Conv3x3::runs(64, 64)) {
    // float32: oneDNN's direct convolution against the float32 Winograd kernel of this CPU's widest vectors
    // (its rate counts the direct convolution's multiply-adds, so it can exceed the CPU's peak).
    const lrf::WinogradF32Conv3x3 winograd(w, {});
    alternate("conv-fp32", reps, flops, "direct", "winograd", [&](bool by_winograd) {
      at::Tensor y = by_winograd ? winograd.forward(x, false) : at::conv2d(x, w, {}, 1, 1);
    });
    // oneDNN's own float32 Winograd (an AVX-512 kernel in oneDNN 2.x) against lrf's, where oneDNN builds it.
    if (std::unique_ptr<OnednnWinograd> onednn = OnednnWinograd::create(x, w)) {
      alternate("conv-fp32", reps, flops, "onednn-w", "lrf-w", [&](bool by_lrf) {
        if (by_lrf) {
          at::Tensor y = winograd.forward(x, false);
        } else {
          onednn->run();
        }
      });
      at::Tensor y = at::empty_like(x);
      alternate("conv-fp32", reps, flops, "onednn-w+r", "lrf-w", [&](bool by_lrf) {
        if (by_lrf) {
          at::Tensor z = winograd.forward(x, false);
        } else {
          onednn->run_channels_last(x, y);
        }
      });
    }
  }
}

// oneDNN's bf16 weight and bias gradient of a 3x3 convolution (stride 1, padding 1): what training ran
// before Winograd's, and runs where the CPU has no AVX512_BF16.
void direct_weight_gradient(const at::Tensor& grad_output, const at::Tensor& input, const at::Tensor& weight16) {
  at::convolution_backward(grad_output, input, weight16, at::IntArrayRef{weight16.size(0)}, {1, 1}, {1, 1}, {1, 1},
                           false, {0, 0}, 1, {false, true, true});
}

// The weight and bias gradient of a 64->64 3x3 convolution over 4 crops of 96x96, bf16 channels-last:
// oneDNN's direct kernel (what training ran before) against Winograd's transposed transforms.
void bench_weight_gradient(int reps) {
  if (!lrf::WinogradConv3x3::available()) {
    std::printf("wgrad: Winograd not available on this CPU (or switched off); skipped\n\n");
    return;
  }
  torch::NoGradGuard no_grad;
  torch::manual_seed(0);
  const int side = 96, crops = 4;
  const auto bf16_image = [&] {
    return torch::randn({crops, 64, side, side}).to(at::kBFloat16).contiguous(at::MemoryFormat::ChannelsLast);
  };
  const at::Tensor x = bf16_image(), g = bf16_image();
  const at::Tensor w16 = (torch::randn({64, 64, 3, 3}) * 0.05).to(at::kBFloat16);
  alternate("wgrad", reps, 2.0 * kConv64 * side * side * crops, "direct", "winograd", [&](bool by_winograd) {
    if (by_winograd) {
      lrf::winograd_weight_gradient(x, g);
    } else {
      direct_weight_gradient(g, x, w16);
    }
  });
}

// The CPU's own ceiling for the products the convolutions are made of: every thread at once runs
// AVX512_BF16 dot products on 24 independent accumulators held in registers, with no memory access and
// nothing else to do. No bf16 convolution kernel on this CPU multiplies faster. 0 without AVX512_BF16.
#if defined(__x86_64__)
LRF_AVX512_BF16 float dot_product_loop(int64_t iterations) {
  __m512 acc[24];
  for (int i = 0; i < 24; ++i) acc[i] = _mm512_set1_ps(static_cast<float>(i));
  __m512bh a = reinterpret_cast<__m512bh>(_mm512_set1_epi32(0x3F803F80));  // (1, 1)
  const __m512bh b = reinterpret_cast<__m512bh>(_mm512_set1_epi32(0x3C003C00));
  for (int64_t it = 0; it < iterations; ++it) {
#pragma GCC unroll 24
    for (int i = 0; i < 24; ++i) acc[i] = _mm512_dpbf16_ps(acc[i], a, b);
    __asm__ volatile("" : "+v"(a));  // keeps the loop from being folded
  }
  alignas(64) float lanes[16];
  __m512 sum = acc[0];
  for (int i = 1; i < 24; ++i) sum = _mm512_add_ps(sum, acc[i]);
  _mm512_store_ps(lanes, sum);
  return lanes[0];
}
#endif

double dot_product_peak_flops(int reps) {
#if defined(__x86_64__)
  if (!lrf::cpu_has_avx512_bf16()) return 0;
  const int64_t threads = at::get_num_threads(), iterations = 20'000'000;
  double best = 1e30;
  for (int r = 0; r < reps; ++r) {
    const double t0 = now();
    std::atomic<float> sink{0};
    at::parallel_for(0, threads, 1, [&](int64_t begin, int64_t end) {
      for (int64_t t = begin; t < end; ++t) sink = sink + dot_product_loop(iterations);
    });
    best = std::min(best, now() - t0);
  }
  return threads * iterations * 24 * 16 * 2 * 2 / best;  // 16 lanes, 2 pairs, 2 flops each
#else
  (void)reps;
  return 0;
#endif
}

// The products (multiply-adds) each workload still needs under an algorithm, counted layer by layer.
struct Products {
  double decode, encode, refine_decoder, stage1, stage3;
};

Products workload_products(const bench::Algorithm& a) {
  using namespace bench;
  const auto encoder = taef2_encoder_layers(kWidth, kHeight), decoder = taef2_decoder_layers(kWidth, kHeight);
  // The layer lists and the architecture's totals must count the same multiply-adds.
  if (std::abs(direct_flops(encoder) / taef2_encode_flops(kWidth, kHeight) - 1) > 1e-9 ||
      std::abs(direct_flops(decoder) / taef2_decode_flops(kWidth, kHeight) - 1) > 1e-9) {
    lrf::fail("bench_autoencoder: the layer lists disagree with taef2_encode_flops / taef2_decode_flops");
  }
  Products p{};
  p.decode = inference_products(decoder, a);
  p.encode = inference_products(encoder, a);
  // The refinement's decoder share, a whole view: the decoder's training forward and input gradient down
  // to the latent, and the weight gradients of the layers at up to 2x the latent's resolution (the
  // default --decoder-scale 2: the first conv, the 1/8 blocks, the first upsampling conv, the 1/4 blocks).
  std::vector<ConvLayer> coarse(decoder.begin(), decoder.begin() + 1 + 3 * 4 + 1 + 3 * 3);
  p.refine_decoder = training_products(decoder, a) + training_products(decoder, a) + weight_gradient_products(coarse, a);
  // Stage I per crop: the trained encoder's forward, input gradient (not into the image) and weight
  // gradient, the frozen decoder's forward and input gradient (down to the latent), the original
  // encoder's forward (inference: no gradient recorded).
  const auto e192 = taef2_encoder_layers(192, 192), d192 = taef2_decoder_layers(192, 192);
  const double encoder_trained =
      training_products(e192, a) + training_products(e192, a, false) + weight_gradient_products(e192, a);
  p.stage1 = 4 * (encoder_trained + 2 * training_products(d192, a) + inference_products(e192, a));
  // Stage III per crop: the trained decoder's forward, input gradient (not into the rendered latent) and
  // weight gradient.
  const auto d128 = taef2_decoder_layers(128, 128);
  p.stage3 = 4 * (training_products(d128, a) + training_products(d128, a, false) + weight_gradient_products(d128, a));
  return p;
}

// The CPU's float32 ceiling per instruction set: every thread runs FMAs on independent accumulators held
// in registers (12 AVX2 or 24 AVX-512 vectors), with no memory access and nothing else to do.
#if defined(__x86_64__)
__attribute__((target("avx2,fma"))) float fma_loop_avx2(int64_t iterations) {
  __m256 acc[12];
  for (int i = 0; i < 12; ++i) acc[i] = _mm256_set1_ps(static_cast<float>(i));
  __m256 a = _mm256_set1_ps(1.0f);
  const __m256 b = _mm256_set1_ps(1e-7f);
  for (int64_t it = 0; it < iterations; ++it) {
#pragma GCC unroll 12
    for (int i = 0; i < 12; ++i) acc[i] = _mm256_fmadd_ps(acc[i], a, b);
    __asm__ volatile("" : "+x"(a));
  }
  __m256 sum = acc[0];
  for (int i = 1; i < 12; ++i) sum = _mm256_add_ps(sum, acc[i]);
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, sum);
  return lanes[0];
}

__attribute__((target("avx512f"))) float fma_loop_avx512(int64_t iterations) {
  __m512 acc[24];
  for (int i = 0; i < 24; ++i) acc[i] = _mm512_set1_ps(static_cast<float>(i));
  __m512 a = _mm512_set1_ps(1.0f);
  const __m512 b = _mm512_set1_ps(1e-7f);
  for (int64_t it = 0; it < iterations; ++it) {
#pragma GCC unroll 24
    for (int i = 0; i < 24; ++i) acc[i] = _mm512_fmadd_ps(acc[i], a, b);
    __asm__ volatile("" : "+v"(a));
  }
  __m512 sum = acc[0];
  for (int i = 1; i < 24; ++i) sum = _mm512_add_ps(sum, acc[i]);
  alignas(64) float lanes[16];
  _mm512_store_ps(lanes, sum);
  return lanes[0];
}
#endif

// FLOP/s of float32 FMAs at `level` on every thread at once (2 flops each), best of `reps`.
double fma_peak_flops(lrf::SimdLevel level, int reps) {
#if defined(__x86_64__)
  if (lrf::cpu_simd_level() < level || level == lrf::SimdLevel::baseline) return 0;
  const int64_t threads = at::get_num_threads(), iterations = 20'000'000;
  const bool wide = level == lrf::SimdLevel::avx512;
  double best = 1e30;
  for (int r = 0; r < reps; ++r) {
    const double t0 = now();
    std::atomic<float> sink{0};
    at::parallel_for(0, threads, 1, [&](int64_t begin, int64_t end) {
      for (int64_t t = begin; t < end; ++t) sink = sink + (wide ? fma_loop_avx512(iterations) : fma_loop_avx2(iterations));
    });
    best = std::min(best, now() - t0);
  }
  return static_cast<double>(threads) * iterations * (wide ? 24 * 16 : 12 * 8) * 2 / best;
#else
  (void)level, (void)reps;
  return 0;
#endif
}

// The float32 floors per instruction set: the products each workload needs with the float32 Winograd
// kernels of that width (F(4x4): a quarter of the direct multiply-adds for the layers they take) and
// with direct convolutions only, at that width's FMA peak.
void bench_fp32_floors(int reps) {
  for (lrf::SimdLevel level : {lrf::SimdLevel::avx2, lrf::SimdLevel::avx512}) {
    const double peak = fma_peak_flops(level, reps);
    if (peak <= 0) {
      std::printf("fp32 floor (%s): this CPU has no %s; skipped\n", lrf::simd_level_name(level),
                  lrf::simd_level_name(level));
      continue;
    }
    const int lanes = level == lrf::SimdLevel::avx512 ? 16 : 8;
    const Products winograd = workload_products(bench::Algorithm{false, lanes, 0.25});
    const Products direct = workload_products(bench::Algorithm{false, 0, 1});
    std::printf("fp32 floor (%s): FMA peak %.0f GFLOP/s here (all threads, on registers); products alone, "
                "Winograd F(4x4) / direct:\n",
                lrf::simd_level_name(level), peak * 1e-9);
    auto row = [&](const char* what, double w, double d) {
      std::printf("fp32 floor (%s): %-40s %7.1f / %7.1f GFLOP  >= %7.1f / %7.1f ms\n", lrf::simd_level_name(level),
                  what, 2 * w * 1e-9, 2 * d * 1e-9, 2e3 * w / peak, 2e3 * d / peak);
    };
    row("decode 504x376", winograd.decode, direct.decode);
    row("encode 504x376", winograd.encode, direct.encode);
    row("refinement's decoder share (504x376)", winograd.refine_decoder, direct.refine_decoder);
    row("Stage I step (4 crops of 192x192)", winograd.stage1, direct.stage1);
    row("Stage III step (4 crops of 128x128)", winograd.stage3, direct.stage3);
  }
  std::printf("\n");
  std::fflush(stdout);
}

// The least time each measured workload can take on this CPU if every convolution ran as fast as the
// fastest one measured here (a 64->64 3x3 at 504x376, bf16, channels-last, through libtorch's path or
// the fused one, best of `reps`): multiply-adds counted from the architecture, as in the GFLOP/s
// figures. Below this bound only fewer multiply-adds or a faster kernel help, not less overhead.
void bench_bounds(int reps) {
  torch::NoGradGuard no_grad;
  torch::manual_seed(0);
  const at::Tensor x = torch::rand({1, 64, kHeight, kWidth}).contiguous(at::MemoryFormat::ChannelsLast).to(at::kBFloat16);
  const at::Tensor w = torch::randn({64, 64, 3, 3}) * 0.05;
  const at::Tensor w16 = w.contiguous(at::MemoryFormat::ChannelsLast).to(at::kBFloat16);
  lrf::FusedConv2d fused(w, {}, 1, 1);
  // Direct: at::conv2d's bf16 convolution, what training's autograd path runs. Inference: the fused
  // layer, which is Winograd's F(2x2, 3x3) where the CPU has AVX512_BF16 (4/9 of the multiply-adds; its
  // rate below counts the direct convolution's, so it can exceed the CPU's peak).
  // Weight gradients: oneDNN's direct one, or Winograd's where the CPU has AVX512_BF16.
  const bool winograd = lrf::WinogradConv3x3::available();
  double best_direct = 1e30, best_inference = 1e30, best_weight = 1e30;
  for (int r = 0; r < reps + 1; ++r) {
    for (int way = 0; way < 3; ++way) {
      const double t0 = now();
      if (way == 0) {
        at::Tensor y = at::conv2d(x, w16, {}, 1, 1);
      } else if (way == 1) {
        at::Tensor y = fused.forward(x, true);
      } else if (winograd) {
        lrf::winograd_weight_gradient(x, x);
      } else {
        direct_weight_gradient(x, x, w16);
      }
      if (r == 0) continue;  // the first round builds the kernels
      double& best = way == 0 ? best_direct : way == 1 ? best_inference : best_weight;
      best = std::min(best, now() - t0);
    }
  }
  const double conv_flops = 2.0 * kConv64 * kWidth * kHeight;
  const double direct = conv_flops / best_direct;
  const double inference = conv_flops / std::min(best_direct, best_inference);
  const double weight_gradient = conv_flops / best_weight;
  std::printf("bounds: fastest bf16 64->64 3x3 convolution at %dx%d here: direct %.0f GFLOP/s, inference (%s) %.0f, "
              "weight gradient (%s) %.0f\n",
              kWidth, kHeight, direct * 1e-9, winograd ? "Winograd" : "oneDNN direct", inference * 1e-9,
              winograd ? "Winograd" : "oneDNN direct", weight_gradient * 1e-9);
  auto bound = [&](const char* what, double flops, double seconds, const char* target) {
    std::printf("bounds: %-44s %7.1f GFLOP  >= %7.1f ms  <= %6.2f /s   (%s)\n", what, flops * 1e-9, 1e3 * seconds,
                1 / seconds, target);
  };
  const double encode = taef2_encode_flops(kWidth, kHeight);
  const double decode_fused = taef2_decode_flops(kWidth, kHeight) - taef2_upsampling_saving_flops(kWidth, kHeight);
  bound("decode 504x376 (fused)", decode_fused, decode_fused / inference, "issue 17: >= 20 /s");
  bound("encode 504x376", encode, encode / inference, "issue 17: >= 10 /s");
  // Stage I, per 192x192 crop (4 per step): the trained encoder forward, data and weight gradients, the
  // frozen decoder forward and data gradient, the original encoder forward. The weight gradients run at
  // the weight gradient's rate, every other pass at inference's (Winograd, where the CPU has
  // AVX512_BF16, runs all three passes in training too).
  const double e192 = taef2_encode_flops(192, 192), d192 = taef2_decode_flops(192, 192);
  bound("Stage I step (4 crops of 192x192)", 4 * (4 * e192 + 2 * d192),
        4 * ((3 * e192 + 2 * d192) / inference + e192 / weight_gradient), "issue 17: <= 0.3 s");
  // Stage III, per 128x128 crop (2 + 2 per step): the trained decoder forward, data and weight gradients.
  const double d128 = taef2_decode_flops(128, 128);
  bound("Stage III step (4 crops of 128x128)", 4 * 3 * d128, 4 * (2 * d128 / inference + d128 / weight_gradient),
        "issue 17: <= 0.3 s");

  // The floor under those bounds: the products alone, at the CPU's dot-product peak, with the transforms,
  // memory traffic and every other pass free.
  const double peak = dot_product_peak_flops(reps);
  if (!winograd || peak <= 0) {
    std::printf("floor: needs AVX512_BF16 (and Winograd on); skipped\n\n");
    std::fflush(stdout);
    return;
  }
  const bool three = lrf::WinogradConv3x3::chosen_tiles() == lrf::WinogradConv3x3::Tiles::f3x3;
  const double share = three ? 25.0 / 81 : 16.0 / 36;
  std::printf("floor: bf16 dot products peak at %.0f GFLOP/s here (all threads, on registers); the products "
              "alone with %s tiles:\n",
              peak * 1e-9, three ? "3x3" : "2x2");
  auto floor = [&](const char* what, double products, const char* target) {
    const double seconds = 2 * products / peak;
    std::printf("floor: %-44s %7.1f GFLOP  >= %7.1f ms  <= %6.2f /s   (%s)\n", what, 2 * products * 1e-9,
                1e3 * seconds, 1 / seconds, target);
  };
  const Products products = workload_products(bench::Algorithm{true, 0, share});
  floor("decode 504x376", products.decode, "issue 17: >= 20 /s");
  floor("encode 504x376", products.encode, "issue 17: >= 10 /s");
  floor("Stage I step (4 crops of 192x192)", products.stage1, "issue 17: <= 0.3 s");
  floor("Stage III step (4 crops of 128x128)", products.stage3, "issue 17: <= 0.3 s");
  std::printf("\n");
  std::fflush(stdout);
}

void bench_taef2(lrf::Autoencoder& ae, const std::set<std::string>& cases, int reps) {
  torch::manual_seed(0);
  at::Tensor x = fern_image(0);
  at::Tensor z;
  {
    torch::NoGradGuard no_grad;
    ae.set_precision(Precision::fp32);
    z = ae.encode(x);
  }
  if (cases.count("encode")) {
    torch::NoGradGuard no_grad;
    ab("encode", reps, taef2_encode_flops(kWidth, kHeight), [&](Precision p) {
      ae.set_precision(p);
      ae.encode(x);
    });
  }
  if (cases.count("decode")) {
    torch::NoGradGuard no_grad;
    ab("decode", reps, taef2_decode_flops(kWidth, kHeight), [&](Precision p) {
      ae.set_precision(p);
      ae.decode(z);
    });
  }
  if (cases.count("fused")) {
    auto* tiny = dynamic_cast<lrf::TinyAutoencoder*>(&ae);
    torch::NoGradGuard no_grad;
    for (Precision p : {Precision::bf16, Precision::fp32}) {
      ae.set_precision(p);
      const std::string tag = p == Precision::bf16 ? "-bf16" : "-fp32";
      alternate("encode" + tag, reps, taef2_encode_flops(kWidth, kHeight), "modules", "fused", [&](bool fused) {
        tiny->set_fused_layers(fused);
        ae.encode(x);
      });
      alternate("decode" + tag, reps, taef2_decode_flops(kWidth, kHeight), "modules", "fused", [&](bool fused) {
        tiny->set_fused_layers(fused);
        ae.decode(z);
      });
    }
    tiny->set_fused_layers(lrf::fused_conv_enabled());
  }
  if (cases.count("backward")) {
    ae.set_decoder_trainable(false);
    at::Tensor upstream = torch::randn({1, 3, kHeight, kWidth});
    // The backward costs about twice the forward (data gradients only: the weights are frozen).
    ab("backward", reps, 2 * taef2_decode_flops(kWidth, kHeight), [&](Precision p) {
      ae.set_precision(p);
      at::Tensor zz = z.detach().requires_grad_(true);
      ae.decode_unclamped(zz).backward(upstream);
    });
    ae.set_decoder_trainable(true);
  }
}

void bench_tiles(int reps) {
  if (!lrf::WinogradConv3x3::available()) {
    std::printf("tiles: Winograd not available on this CPU (or switched off); skipped\n\n");
    return;
  }
  torch::NoGradGuard no_grad;
  const at::Tensor x = fern_image(0);
  const char* before = std::getenv("LRF_WINOGRAD_TILE");
  const std::string kept = before ? before : "";
  // The fused layers are built on first use, so each copy runs once under its own setting.
  auto built_with = [&](const char* tile) {
    setenv("LRF_WINOGRAD_TILE", tile, 1);
    auto ae = make_taef2();
    ae->set_precision(Precision::bf16);
    ae->decode(ae->encode(x));
    return ae;
  };
  auto two = built_with("2"), three = built_with("3");
  if (before) {
    setenv("LRF_WINOGRAD_TILE", kept.c_str(), 1);
  } else {
    unsetenv("LRF_WINOGRAD_TILE");
  }
  const at::Tensor z = two->encode(x);
  alternate("decode", reps, taef2_decode_flops(kWidth, kHeight), "2x2", "3x3",
            [&](bool by_three) { (by_three ? three : two)->decode(z); });
  alternate("encode", reps, taef2_encode_flops(kWidth, kHeight), "2x2", "3x3",
            [&](bool by_three) { (by_three ? three : two)->encode(x); });
}

// The decoder's last layer, 64 -> 3 at 504x376 in bf16: libtorch's convolution (oneDNN's direct kernel,
// what training's forward runs) against NarrowConv3x3 (inference's, where the CPU has AVX512_BF16),
// alternated.
void bench_narrow(int reps) {
  if (!lrf::NarrowConv3x3::available()) {
    std::printf("narrow: needs AVX512_BF16 (and LRF_FUSED_CONV not 0); skipped\n\n");
    return;
  }
  torch::NoGradGuard no_grad;
  torch::manual_seed(0);
  const at::Tensor x = torch::rand({1, 64, kHeight, kWidth}).contiguous(at::MemoryFormat::ChannelsLast).to(at::kBFloat16);
  const at::Tensor w = torch::randn({3, 64, 3, 3}) * 0.05, b = torch::randn({3});
  const at::Tensor w16 = w.contiguous(at::MemoryFormat::ChannelsLast).to(at::kBFloat16), b16 = b.to(at::kBFloat16);
  const lrf::NarrowConv3x3 narrow(w, b);
  alternate("narrow", reps, 2.0 * 3 * 64 * 9 * kWidth * kHeight, "onednn", "narrow", [&](bool by_narrow) {
    if (by_narrow) {
      narrow.forward(x, false);
    } else {
      at::conv2d(x, w16, b16, 1, 1);
    }
  });
}

// What the explicit casts of the fp32 master weights to bf16 cost in one step: casting every weight of
// the model once (the alternative, a bf16 copy refreshed after each Adam step, casts each once per step
// too, so this bounds what it could save).
double weight_cast_ms(const std::vector<at::Tensor>& params) {
  torch::NoGradGuard no_grad;
  const double t0 = now();
  for (int k = 0; k < 5; ++k) {
    for (const auto& p : params) p.to(at::kBFloat16);
  }
  return (now() - t0) / 5 * 1e3;
}

void bench_stage1(int reps) {
  lrf::SceneOptions so;
  so.images_dir = "images_8";
  std::vector<lrf::PairScene> scenes;
  scenes.push_back(lrf::load_pair_scene(shared_dir() + "/scenes/llff-fern", so, 640, "", 15));
  lrf::EncoderFinetuneOptions o;
  o.batch.pairs = 2;
  o.batch.crop = 192;
  auto model = make_taef2(), original = make_taef2();
  original->set_encoder_trainable(false);
  original->set_decoder_trainable(false);
  model->set_decoder_trainable(false);
  lrf::ParamAdam adam(model->encoder_parameters(), {1e-5});
  lrf::PairBatch batch = lrf::sample_pair_batch(scenes, o.batch, 0, 0);
  std::printf("stage1: %lld images of %lldx%lld per step; casting every weight once to bf16: %.1f ms\n",
              static_cast<long long>(batch.images.size(0)), static_cast<long long>(batch.images.size(2)),
              static_cast<long long>(batch.images.size(3)), weight_cast_ms(model->encoder_parameters()) +
              weight_cast_ms(model->decoder_parameters()));
  ab("stage1", reps, 0, [&](Precision p) {
    model->set_precision(p);
    original->set_precision(p);
    adam.zero_grad();
    lrf::Stage1Losses l = lrf::stage1_losses(*model, *original, batch, o);
    l.total.backward();
    adam.step();
  });
}

void bench_stage3(int reps) {
  auto ae = make_taef2();
  ae->set_encoder_trainable(false);
  // Latents of two fern views (crops of encoded views stand in for rendered ones: same sizes and cost).
  std::vector<at::Tensor> z, x;
  {
    torch::NoGradGuard no_grad;
    for (int i : {0, 8}) {
      at::Tensor image = fern_image(i);
      x.push_back(image);
      z.push_back(ae->encode(image));
    }
  }
  const int64_t crop = 128, lc = crop / 8;
  auto crops = [&](int k) {
    // Two crops per group at fixed places (the cost does not depend on where).
    std::vector<at::Tensor> zs, xs;
    for (int j = 0; j < 2; ++j) {
      const int64_t ly = 4 * j + k, lx = 10 * j + 3 * k;
      zs.push_back(z[static_cast<size_t>(k)][0].narrow(1, ly, lc).narrow(2, lx, lc));
      xs.push_back(x[static_cast<size_t>(k)][0].narrow(1, 8 * ly, crop).narrow(2, 8 * lx, crop));
    }
    return std::make_pair(at::stack(zs), at::stack(xs));
  };
  auto [z_train, x_train] = crops(0);
  auto [z_novel, x_novel] = crops(1);
  lrf::ParamAdam adam(ae->decoder_parameters(), {1e-5});
  std::printf("stage3: 2 + 2 crops of %lldx%lld per step; casting every decoder weight once to bf16: %.1f ms\n",
              static_cast<long long>(crop), static_cast<long long>(crop), weight_cast_ms(ae->decoder_parameters()));
  ab("stage3", reps, 0, [&](Precision p) {
    ae->set_precision(p);
    adam.zero_grad();
    at::Tensor loss = 0.5 * (ae->decode(z_train) - x_train).abs().mean() + 0.5 * (ae->decode(z_novel) - x_novel).abs().mean();
    loss.backward();
    adam.step();
  });
  // Stage III's step as it runs (training, held-out and round-trip crops, each term its own decode) against
  // the same three terms from one decode of the groups stacked into one batch.
  auto [z_round, x_round] = crops(0);
  ae->set_precision(Precision::fp32);
  const std::vector<lrf::Stage3Term> terms{{"l1_train", 1, {z_train, x_train}},
                                           {"l1_novel", 1, {z_novel, x_novel}},
                                           {"l1_roundtrip", 1, {z_round, x_round}}};
  const lrf::BatchShare whole = lrf::batch_share(2, 0, 1);
  alternate("stage3x3", reps, 0, "apart", "stacked", [&](bool stacked) {
    adam.zero_grad();
    at::Tensor loss = torch::zeros({});
    if (stacked) {
      for (const at::Tensor& l : lrf::stage3_term_losses(*ae, terms, whole, 0)) loss = loss + l;
    } else {
      for (const auto& t : terms) loss = loss + (ae->decode_unclamped(t.crops.first) - t.crops.second).abs().mean();
    }
    loss.backward();
    adam.step();
  });
}

void bench_quality(lrf::Autoencoder& ae) {
  torch::NoGradGuard no_grad;
  std::printf("quality: TAEF2 round trip (encode + decode) PSNR on llff-fern images_8 test views, 504x376\n");
  std::printf("%-6s %9s %9s %9s %14s\n", "view", "fp32 dB", "bf16 dB", "diff dB", "fp32 vs bf16 dB");
  double s32 = 0, s16 = 0;
  for (int i : {0, 8, 16}) {
    at::Tensor x = fern_image(i);
    ae.set_precision(Precision::fp32);
    at::Tensor y32 = ae.decode(ae.encode(x));
    ae.set_precision(Precision::bf16);
    at::Tensor y16 = ae.decode(ae.encode(x));
    const double p32 = lrf::psnr(y32[0], x[0]), p16 = lrf::psnr(y16[0], x[0]), between = lrf::psnr(y16[0], y32[0]);
    s32 += p32;
    s16 += p16;
    std::printf("%-6d %9.3f %9.3f %+9.3f %14.2f\n", i, p32, p16, p16 - p32, between);
  }
  std::printf("%-6s %9.3f %9.3f %+9.3f\n\n", "mean", s32 / 3, s16 / 3, (s16 - s32) / 3);
  std::fflush(stdout);
}

void bench_kl(int reps) {
  torch::NoGradGuard no_grad;
  lrf::KLAutoencoder ae{lrf::KLConfig{}};
  ae.set_channels_last(true);
  torch::manual_seed(0);
  at::Tensor x = torch::rand({1, 3, kHeight, kWidth});
  at::Tensor z = ae.encode(x);
  ab("kl-encode", reps, 0, [&](Precision p) {
    ae.set_precision(p);
    ae.encode(x);
  });
  ab("kl-decode", reps, 0, [&](Precision p) {
    ae.set_precision(p);
    ae.decode(z);
  });
}

// One instruction-set path: the environment that selects it and the precision it computes in.
struct Path {
  std::string name;
  std::vector<std::pair<const char*, const char*>> env;  // set while the path runs ("" unsets)
  Precision precision;
};

// The paths this CPU can run: bf16 where it has native bf16, float32 Winograd on AVX-512F and on AVX2
// where it has them, and float32 with oneDNN's direct convolutions (what every CPU without native bf16
// ran before the float32 kernels).
std::vector<Path> cpu_paths() {
  std::vector<Path> paths;
  if (lrf::cpu_has_avx512_bf16()) paths.push_back({"bf16", {{"LRF_CPU_ISA", ""}, {"LRF_WINOGRAD", ""}}, Precision::bf16});
  if (lrf::cpu_simd_level() >= lrf::SimdLevel::avx512)
    paths.push_back({"avx512-fp32", {{"LRF_CPU_ISA", "avx512"}, {"LRF_WINOGRAD", ""}}, Precision::fp32});
  if (lrf::cpu_simd_level() >= lrf::SimdLevel::avx2)
    paths.push_back({"avx2-fp32", {{"LRF_CPU_ISA", "avx2"}, {"LRF_WINOGRAD", ""}}, Precision::fp32});
  paths.push_back({"direct-fp32", {{"LRF_CPU_ISA", ""}, {"LRF_WINOGRAD", "0"}}, Precision::fp32});
  return paths;
}

void enter(const Path& path) {
  for (const auto& [name, value] : path.env) {
    if (*value) {
      setenv(name, value, 1);
    } else {
      unsetenv(name);
    }
  }
}

// The workloads of one path, on models built while the path's environment is set (the fused inference
// layers choose their kernels when built).
struct PathWorkloads {
  std::unique_ptr<lrf::Autoencoder> ae, stage1_model, stage1_original;
  std::unique_ptr<lrf::ParamAdam> stage1_adam, stage3_adam, refine_adam;
  std::vector<std::function<void()>> runs;  // decode, encode, refinement's decoder share, Stage I, Stage III
};

const char* const kWorkloads[] = {"decode 504x376", "encode 504x376", "refinement's decoder share 504x376",
                                  "Stage I step (4 x 192x192)", "Stage III step (4 x 128x128)"};

// Compares the paths this CPU has on TAEF2's workloads, alternating their order at each repetition, and
// prints each workload's median time per path with its float32 floor (products at the FMA peak of the
// path's width; bounds prints how those are counted).
void bench_paths(int reps) {
  const std::vector<Path> paths = cpu_paths();
  lrf::SceneOptions so;
  so.images_dir = "images_8";
  std::vector<lrf::PairScene> scenes;
  scenes.push_back(lrf::load_pair_scene(shared_dir() + "/scenes/llff-fern", so, 640, "", 15));
  lrf::EncoderFinetuneOptions o;
  o.batch.pairs = 2;
  o.batch.crop = 192;
  const lrf::PairBatch batch = lrf::sample_pair_batch(scenes, o.batch, 0, 0);
  const at::Tensor x = fern_image(0);
  const at::Tensor upstream = torch::randn({1, 3, kHeight, kWidth});
  std::vector<PathWorkloads> work(paths.size());
  for (size_t k = 0; k < paths.size(); ++k) {
    enter(paths[k]);
    PathWorkloads& w = work[k];
    w.ae = make_taef2();
    w.ae->set_precision(paths[k].precision);
    at::Tensor z;
    {
      torch::NoGradGuard no_grad;
      z = w.ae->encode(x);
    }
    w.stage1_model = make_taef2();
    w.stage1_original = make_taef2();
    for (auto* m : {w.stage1_model.get(), w.stage1_original.get()}) m->set_precision(paths[k].precision);
    w.stage1_original->set_encoder_trainable(false);
    w.stage1_original->set_decoder_trainable(false);
    w.stage1_model->set_decoder_trainable(false);
    w.stage1_adam = std::make_unique<lrf::ParamAdam>(w.stage1_model->encoder_parameters(), lrf::AdamOptions{1e-5});
    auto* ae = w.ae.get();
    w.runs.push_back([ae, z] {
      torch::NoGradGuard no_grad;
      ae->decode(z);
    });
    w.runs.push_back([ae, x] {
      torch::NoGradGuard no_grad;
      ae->encode(x);
    });
    w.runs.push_back([ae, z, upstream] {
      ae->set_decoder_trainable(true, 2);
      at::Tensor zz = z.detach().requires_grad_(true);
      ae->decode_unclamped(zz).backward(upstream);
      for (auto& p : ae->decoder_parameters()) p.mutable_grad() = at::Tensor();
    });
    auto* model = w.stage1_model.get();
    auto* original = w.stage1_original.get();
    auto* adam = w.stage1_adam.get();
    w.runs.push_back([model, original, adam, &batch, &o] {
      adam->zero_grad();
      lrf::stage1_losses(*model, *original, batch, o).total.backward();
      adam->step();
    });
    // Stage III: crops of the encoded view stand in for rendered latents (same sizes and cost).
    w.stage3_adam = std::make_unique<lrf::ParamAdam>(ae->decoder_parameters(), lrf::AdamOptions{1e-5});
    auto* adam3 = w.stage3_adam.get();
    const at::Tensor zc = z.narrow(2, 4, 16).narrow(3, 4, 16).repeat({4, 1, 1, 1});
    const at::Tensor xc = x.narrow(2, 32, 128).narrow(3, 32, 128).repeat({4, 1, 1, 1});
    w.runs.push_back([ae, adam3, zc, xc] {
      ae->set_decoder_trainable(true);
      adam3->zero_grad();
      (ae->decode(zc) - xc).abs().mean().backward();
      adam3->step();
    });
  }
  const size_t n_work = std::size(kWorkloads);
  std::vector<std::vector<std::vector<double>>> times(paths.size(), std::vector<std::vector<double>>(n_work));
  for (int r = -1; r < reps; ++r) {  // round -1 warms up (oneDNN builds its kernels on first use)
    for (size_t j = 0; j < paths.size(); ++j) {
      const size_t k = (j + static_cast<size_t>(std::max(r, 0))) % paths.size();
      enter(paths[k]);
      for (size_t i = 0; i < n_work; ++i) {
        const double t0 = now();
        work[k].runs[i]();
        if (r >= 0) times[k][i].push_back(now() - t0);
      }
    }
  }
  std::printf("paths: median of %d repetitions, ms (the paths alternate their order); floor: the products alone at "
              "the FMA peak (fp32 paths)\n", reps);
  std::printf("%-38s", "workload");
  for (const auto& p : paths) std::printf(" %13s %8s", p.name.c_str(), "floor");
  std::printf("\n");
  std::vector<double> peaks;
  std::vector<Products> products;
  for (const auto& p : paths) {
    const bool avx512 = p.name == "avx512-fp32", avx2 = p.name == "avx2-fp32";
    peaks.push_back(avx512 ? fma_peak_flops(lrf::SimdLevel::avx512, 2)
                    : (avx2 || p.name == "direct-fp32") ? fma_peak_flops(lrf::SimdLevel::avx2, 2)
                                                        : 0);
    products.push_back(workload_products(bench::Algorithm{false, avx512 ? 16 : avx2 ? 8 : 0, avx512 || avx2 ? 0.25 : 1}));
  }
  for (size_t i = 0; i < n_work; ++i) {
    std::printf("%-38s", kWorkloads[i]);
    for (size_t k = 0; k < paths.size(); ++k) {
      const Products& pr = products[k];
      const double macs = i == 0 ? pr.decode : i == 1 ? pr.encode : i == 2 ? pr.refine_decoder : i == 3 ? pr.stage1 : pr.stage3;
      std::printf(" %13.1f", 1e3 * median(times[k][i]));
      if (peaks[k] > 0) {
        std::printf(" %8.1f", 2e3 * macs / peaks[k]);
      } else {
        std::printf(" %8s", "-");
      }
    }
    std::printf("\n");
  }
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does, so that the figures match its runs
  int threads = 2, reps = 5;
  std::set<std::string> cases;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--threads") == 0 && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::max(1, std::atoi(argv[++i]));
    } else {
      cases.insert(argv[i]);
    }
  }
  const std::set<std::string> known = {"conv",     "bounds", "wgrad",  "tiles",   "encode", "decode",
                                       "fused",    "backward", "stage1", "stage3", "quality", "kl", "narrow", "paths"};
  for (const auto& c : cases) {
    if (!known.count(c)) {
      std::string names;
      for (const auto& k : known) names += (names.empty() ? "" : " ") + k;
      std::fprintf(stderr, "bench_autoencoder: unknown case '%s' (%s)\n", c.c_str(), names.c_str());
      return 2;
    }
  }
  if (cases.empty()) {
    cases = {"conv", "bounds", "wgrad", "tiles", "narrow", "encode", "decode", "backward", "stage1", "stage3", "quality"};
  }
  lrf::set_thread_count(threads);
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) > 0) std::printf("load average at start: %.2f; %d threads; %d repetitions\n", load[0], threads, reps);
  std::printf("CPU native bf16 (AVX512_BF16 or AMX-BF16): %s\n\n", lrf::cpu_reports_bf16() ? "yes" : "no");
  try {
    if (cases.count("conv")) bench_conv(reps);
    if (cases.count("bounds")) {
      bench_bounds(reps);
      bench_fp32_floors(reps);
    }
    if (cases.count("wgrad")) bench_weight_gradient(reps);
    if (cases.count("tiles")) bench_tiles(reps);
    if (cases.count("narrow")) bench_narrow(reps);
    if (cases.count("encode") || cases.count("decode") || cases.count("fused") || cases.count("backward") || cases.count("quality")) {
      auto ae = make_taef2();
      bench_taef2(*ae, cases, reps);
      if (cases.count("quality")) bench_quality(*ae);
    }
    if (cases.count("stage1")) bench_stage1(reps);
    if (cases.count("stage3")) bench_stage3(reps);
    if (cases.count("kl")) bench_kl(std::min(reps, 3));
    if (cases.count("paths")) bench_paths(reps);
  } catch (const lrf::Error& e) {
    std::fprintf(stderr, "bench_autoencoder: %s\n", e.what());
    return 1;
  }
  return 0;
}
