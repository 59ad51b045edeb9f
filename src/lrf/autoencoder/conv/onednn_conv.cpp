#include "lrf/autoencoder/conv/onednn_conv.h"

#include <atomic>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <oneapi/dnnl/dnnl.hpp>

#include "lrf/autoencoder/conv/conv_destination.h"
#include "lrf/autoencoder/conv/narrow_conv.h"
#include "lrf/autoencoder/conv/winograd_conv.h"
#include "lrf/autoencoder/conv/winograd_f32.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

using dt = dnnl::memory::data_type;
using tag = dnnl::memory::format_tag;

dnnl::engine& cpu_engine() {
  static dnnl::engine engine(dnnl::engine::kind::cpu, 0);
  return engine;
}

std::string shape_of(const at::Tensor& t) { return c10::str(t.sizes()); }

}  // namespace

struct FusedConv2d::Impl {
  // One primitive per input shape, dtype and epilogue, with the weights in the layout it chose.
  struct Prepared {
    dnnl::convolution_forward conv;
    dnnl::memory::desc src, dst, scratch;
    dnnl::memory weights, bias;
    int64_t out_h = 0, out_w = 0;
  };
  using Key = std::tuple<int, int64_t, int64_t, int64_t, bool, bool>;

  std::vector<float> weight;  // [O, I, kh, kw]
  std::vector<float> bias;    // [O]; empty for a layer without bias
  int64_t outputs = 0, inputs = 0, kh = 0, kw = 0;
  int stride = 1, padding = 0;
  std::mutex mutex;
  std::map<Key, std::shared_ptr<const Prepared>> cache;
  // The bf16 path of a 3x3 convolution (stride 1, padding 1) whose channel counts it takes.
  std::unique_ptr<WinogradConv3x3> winograd;
  // The float32 path of a 3x3 convolution (stride 1, padding 1) where the CPU has AVX2 or AVX-512F.
  std::unique_ptr<WinogradF32Conv3x3> winograd_f32;
  // The bf16 path of a 3x3 convolution (stride 1, padding 1) to a few outputs (narrow_conv.h).
  std::unique_ptr<NarrowConv3x3> narrow;
  // Set once oneDNN has refused a bf16 convolution: it has them only on CPUs with AVX-512, so on others
  // (an AVX2 CPU told --precision bf16) every bf16 input takes the float32 path below.
  std::atomic<bool> bf16_unsupported{false};

  std::shared_ptr<const Prepared> prepared(bool bf16, int64_t n, int64_t h, int64_t w, bool relu, bool sum) {
    const Key key{bf16, n, h, w, relu, sum};
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = cache.find(key); it != cache.end()) return it->second;
    auto p = std::make_shared<Prepared>();
    const dt type = bf16 ? dt::bf16 : dt::f32;
    p->out_h = (h + 2 * padding - kh) / stride + 1;
    p->out_w = (w + 2 * padding - kw) / stride + 1;
    p->src = dnnl::memory::desc({n, inputs, h, w}, type, tag::nhwc);
    p->dst = dnnl::memory::desc({n, outputs, p->out_h, p->out_w}, type, tag::nhwc);
    const dnnl::memory::desc weights_any({outputs, inputs, kh, kw}, type, tag::any);
    const dnnl::memory::desc bias_md({outputs}, dt::f32, tag::a);
    const dnnl::memory::dims strides{stride, stride}, pad{padding, padding};
    using conv = dnnl::convolution_forward;
    const auto kind = dnnl::prop_kind::forward_inference;
    const auto algo = dnnl::algorithm::convolution_direct;
    const conv::desc desc = bias.empty() ? conv::desc(kind, algo, p->src, weights_any, p->dst, strides, pad, pad)
                                         : conv::desc(kind, algo, p->src, weights_any, bias_md, p->dst, strides, pad, pad);
    dnnl::post_ops ops;
    if (sum) ops.append_sum(1.f);  // dst = conv + bias + dst
    if (relu) ops.append_eltwise(1.f, dnnl::algorithm::eltwise_relu, 0.f, 0.f);
    dnnl::primitive_attr attr;
    attr.set_post_ops(ops);
    // Scratch memory handed in per call, so that two threads may run one primitive at once.
    attr.set_scratchpad_mode(dnnl::scratchpad_mode::user);
    const conv::primitive_desc pd(desc, attr, cpu_engine());
    p->conv = conv(pd);
    p->scratch = pd.scratchpad_desc();
    dnnl::memory plain({{outputs, inputs, kh, kw}, dt::f32, tag::oihw}, cpu_engine(), weight.data());
    p->weights = dnnl::memory(pd.weights_desc(), cpu_engine());
    dnnl::stream stream(cpu_engine());
    dnnl::reorder(plain, p->weights).execute(stream, plain, p->weights);
    stream.wait();
    if (!bias.empty()) p->bias = dnnl::memory(bias_md, cpu_engine(), bias.data());
    cache.emplace(key, p);
    return p;
  }
};

FusedConv2d::FusedConv2d(const at::Tensor& weight, const at::Tensor& bias, int stride, int padding)
    : impl_(std::make_unique<Impl>()) {
  if (weight.dim() != 4) fail("FusedConv2d: weight must be [O, I, kh, kw], got " + shape_of(weight));
  const at::Tensor w = weight.detach().to(at::kFloat).contiguous();
  impl_->outputs = w.size(0), impl_->inputs = w.size(1), impl_->kh = w.size(2), impl_->kw = w.size(3);
  impl_->weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  if (bias.defined()) {
    if (bias.dim() != 1 || bias.size(0) != impl_->outputs) fail("FusedConv2d: bias must be [O], got " + shape_of(bias));
    const at::Tensor b = bias.detach().to(at::kFloat).contiguous();
    impl_->bias.assign(b.data_ptr<float>(), b.data_ptr<float>() + b.numel());
  }
  if (stride < 1 || padding < 0) fail("FusedConv2d: stride must be positive and padding non-negative");
  impl_->stride = stride;
  impl_->padding = padding;
  const bool same_3x3 = impl_->kh == 3 && impl_->kw == 3 && stride == 1 && padding == 1;
  if (same_3x3 && WinogradConv3x3::takes(impl_->outputs, impl_->inputs) && WinogradConv3x3::available()) {
    impl_->winograd = std::make_unique<WinogradConv3x3>(w, bias, false, WinogradConv3x3::chosen_tiles());
  }
  if (same_3x3 && NarrowConv3x3::takes(impl_->outputs, impl_->inputs) && NarrowConv3x3::available()) {
    impl_->narrow = std::make_unique<NarrowConv3x3>(w, bias);
  }
  if (same_3x3 && WinogradF32Conv3x3::runs(impl_->outputs, impl_->inputs)) {
    impl_->winograd_f32 = std::make_unique<WinogradF32Conv3x3>(w, bias);
  }
}

FusedConv2d::~FusedConv2d() = default;

at::Tensor FusedConv2d::forward_bf16_in_float32(const at::Tensor& input, bool relu, const at::Tensor& residual) const {
  // The bf16 values exactly, float32 products and sums, one rounding of the output: what a bf16
  // convolution computes, except that the weights keep their float32 bits.
  if (!residual.defined()) return forward(input.to(at::kFloat), relu).to(at::kBFloat16);
  conv_destination("FusedConv2d", input, residual, residual.sizes().vec());  // the residual's own checks
  return residual.copy_(forward(input.to(at::kFloat), relu, residual.to(at::kFloat)));
}

FusedConv2d::Kernel FusedConv2d::bf16_kernel() const {
  if (impl_->winograd && WinogradConv3x3::available()) return Kernel::winograd;
  if (impl_->narrow && NarrowConv3x3::available()) return Kernel::narrow;
  return Kernel::onednn;
}

at::Tensor FusedConv2d::forward(const at::Tensor& input, bool relu, const at::Tensor& residual) const {
  Impl& m = *impl_;
  if (input.dim() != 4 || input.size(1) != m.inputs) {
    fail("FusedConv2d: input must be [N, " + std::to_string(m.inputs) + ", H, W], got " + shape_of(input));
  }
  const auto dtype = input.scalar_type();
  if (dtype != at::kBFloat16 && dtype != at::kFloat) fail("FusedConv2d: input must be bf16 or float32");
  if (input.size(2) + 2 * m.padding < m.kh || input.size(3) + 2 * m.padding < m.kw) {
    fail("FusedConv2d: input " + shape_of(input) + " is smaller than the kernel");
  }
  if (dtype == at::kFloat && m.winograd_f32 && WinogradF32Conv3x3::runs(m.outputs, m.inputs)) {
    return m.winograd_f32->forward(input, relu, residual);
  }
  if (dtype == at::kBFloat16) {
    const Kernel kernel = bf16_kernel();
    if (kernel == Kernel::winograd) return m.winograd->forward(input, relu, residual);
    if (kernel == Kernel::narrow) return m.narrow->forward(input, relu, residual);
  }
  const bool bf16 = dtype == at::kBFloat16;
  if (bf16 && m.bf16_unsupported.load()) return forward_bf16_in_float32(input, relu, residual);
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const bool sum = residual.defined();
  std::shared_ptr<const Impl::Prepared> p;
  try {
    p = m.prepared(bf16, x.size(0), x.size(2), x.size(3), relu, sum);
  } catch (const dnnl::error& e) {
    if (bf16) {
      m.bf16_unsupported.store(true);
      return forward_bf16_in_float32(input, relu, residual);
    }
    fail(std::string("FusedConv2d: oneDNN has no convolution for ") + shape_of(x) + ": " + e.what());
  }
  // oneDNN reads the input while it writes the output: they must not share memory.
  const at::Tensor out = conv_destination("FusedConv2d", x, residual, {x.size(0), m.outputs, p->out_h, p->out_w});
  const int64_t scratch_bytes = static_cast<int64_t>(p->scratch.get_size());
  at::Tensor scratch = at::empty({std::max<int64_t>(scratch_bytes, 1)}, x.options().dtype(at::kByte));
  dnnl::memory src(p->src, cpu_engine(), x.data_ptr()), dst(p->dst, cpu_engine(), out.data_ptr());
  dnnl::memory scratchpad(p->scratch, cpu_engine(), scratch.data_ptr());
  std::unordered_map<int, dnnl::memory> args{
      {DNNL_ARG_SRC, src}, {DNNL_ARG_WEIGHTS, p->weights}, {DNNL_ARG_DST, dst}, {DNNL_ARG_SCRATCHPAD, scratchpad}};
  if (!m.bias.empty()) args.emplace(DNNL_ARG_BIAS, p->bias);
  thread_local dnnl::stream stream(cpu_engine());
  try {
    p->conv.execute(stream, args);
    stream.wait();
  } catch (const dnnl::error& e) {
    fail(std::string("FusedConv2d: oneDNN failed: ") + e.what());
  }
  return out;
}

namespace {

// Rows (or columns) of a 3x3 kernel that land on tap r of the 2x2 kernel of phase `a`: in output row
// 2i + a of the upsampled image, kernel rows 0, 1, 2 read upsampled rows 2i + a - 1, 2i + a, 2i + a + 1,
// i.e. input rows i - 1, i, i (a = 0) or i, i, i + 1 (a = 1). The 2x2 convolution with padding 1 puts
// input rows i - 1 + a + r under output row i + a, tap r.
constexpr int kFirst[2][2] = {{0, 1}, {0, 2}};  // [a][r]: first kernel row
constexpr int kLast[2][2] = {{0, 2}, {1, 2}};   // [a][r]: last kernel row (inclusive)

// Phase p = 2a + b's 2x2 kernels as output channels [p·O, (p + 1)·O).
at::Tensor phase_weights(const at::Tensor& weight) {
  const at::Tensor w = weight.detach().to(at::kDouble).contiguous();
  const int64_t o = w.size(0), i = w.size(1);
  at::Tensor out = at::zeros({4 * o, i, 2, 2}, w.options());
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 2; ++c) {
          const at::Tensor taps = w.slice(2, kFirst[a][r], kLast[a][r] + 1).slice(3, kFirst[b][c], kLast[b][c] + 1);
          out.slice(0, (2 * a + b) * o, (2 * a + b + 1) * o).select(2, r).select(2, c).copy_(taps.sum({2, 3}));
        }
  return out.to(at::kFloat);
}

}  // namespace

UpsampledConv2d::UpsampledConv2d(const at::Tensor& weight, const at::Tensor& bias) {
  if (weight.dim() != 4 || weight.size(2) != 3 || weight.size(3) != 3) {
    fail("UpsampledConv2d: weight must be [O, I, 3, 3], got " + shape_of(weight));
  }
  outputs_ = weight.size(0);
  winograd_inputs_ = weight.size(1);
  const at::Tensor b = bias.defined() ? bias.detach().to(at::kFloat).repeat({4}) : at::Tensor();
  phases_ = std::make_unique<FusedConv2d>(phase_weights(weight), b, 1, 1);
  if (WinogradConv3x3::takes(weight.size(0), weight.size(1)) && WinogradConv3x3::available()) {
    winograd_ = std::make_unique<WinogradConv3x3>(weight, bias, true);
  }
  if (WinogradF32Conv3x3::runs(weight.size(0), weight.size(1))) {
    winograd_f32_ = std::make_unique<WinogradF32Conv3x3>(weight, bias, true);
  }
}

UpsampledConv2d::~UpsampledConv2d() = default;

at::Tensor UpsampledConv2d::forward(const at::Tensor& input, bool relu) const {
  if (input.scalar_type() == at::kBFloat16 && winograd_ && WinogradConv3x3::available()) {
    return winograd_->forward(input, relu);
  }
  if (input.scalar_type() == at::kFloat && winograd_f32_ && WinogradF32Conv3x3::runs(outputs_, winograd_inputs_)) {
    return winograd_f32_->forward(input, relu);
  }
  const at::Tensor g = phases_->forward(input, relu);  // [N, 4·O, H + 1, W + 1]
  const int64_t n = g.size(0), h = g.size(2) - 1, w = g.size(3) - 1, o = outputs_;
  at::Tensor out = at::empty({n, o, 2 * h, 2 * w}, g.options().memory_format(at::MemoryFormat::ChannelsLast));
  const int64_t bytes = o * static_cast<int64_t>(g.element_size());
  const char* src = static_cast<const char*>(g.data_ptr());
  char* dst = static_cast<char*>(out.data_ptr());
  at::parallel_for(0, n * 2 * h, 8, [&](int64_t begin, int64_t end) {
    for (int64_t row = begin; row < end; ++row) {
      const int64_t s = row / (2 * h), y = row % (2 * h), a = y & 1, i = y >> 1;
      const char* grid_row = src + ((s * (h + 1) + i + a) * (w + 1)) * 4 * bytes;
      char* out_row = dst + row * 2 * w * bytes;
      for (int64_t x = 0; x < 2 * w; ++x) {
        const int64_t b = x & 1, j = x >> 1;
        std::memcpy(out_row + x * bytes, grid_row + ((j + b) * 4 + 2 * a + b) * bytes, static_cast<size_t>(bytes));
      }
    }
  });
  return out;
}

}  // namespace lrf
