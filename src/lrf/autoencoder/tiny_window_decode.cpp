// TinyAutoencoder::decode_local_window: the decoder's local layers on a window, each layer computed only
// on the part of the window that the layers after it need. A zero-padded 3x3 convolution's outermost ring
// is wrong on a side where the window cuts the image (the padding stands where the image has pixels), so
// that ring is dropped after each convolution; before each layer the ring of context around the wanted
// rectangle is cut down to what the remaining layers need. On sides that are the image's own edges the
// padding is the whole image's, nothing is wrong and nothing is cut until the end.
#include <array>
#include <vector>

#include <torch/torch.h>

#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/autoencoder/tiny_block.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

namespace nn = torch::nn;

// Pixels of context beyond the wanted rectangle, per side, in the current layer's pixels.
struct Ring {
  std::array<int64_t, 4> side{};  // top, left, bottom, right
};

// Removes `k` pixels from each side of an [N, C, H, W] tensor that is not an image edge (edge[s] false).
at::Tensor cut_sides(const at::Tensor& t, const std::array<int64_t, 4>& k) {
  // A slice that keeps everything is not free: its backward allocates a zero gradient of the whole input and
  // copies into it. A whole view has only image edges, so without this every layer paid that twice.
  if (k == std::array<int64_t, 4>{}) return t;
  const int64_t h = t.size(2) - k[0] - k[2], w = t.size(3) - k[1] - k[3];
  if (h < 1 || w < 1) fail("decode_local_window: the window is too small for its decoder");
  return t.narrow(2, k[0], h).narrow(3, k[1], w);
}

// The context each of layers [from, to) needs around the wanted rectangle, in the pixels of its input.
std::vector<int64_t> context_needed(nn::SequentialImpl& layers, size_t from, size_t to) {
  std::vector<int64_t> need(to - from + 1, 0);
  for (size_t i = to; i-- > from;) {
    const auto& m = layers.ptr(i);
    int64_t n = need[i - from + 1];
    if (m->as<nn::Upsample>()) n = (n + 1) / 2;
    else if (m->as<MixedConv2d>()) n += 1;
    else if (m->as<TinyBlock>()) n += 3;
    need[i - from] = n;
  }
  return need;
}

}  // namespace

at::Tensor TinyAutoencoder::decode_local_window(const at::Tensor& features, const CellRect& inner,
                                                const WindowEdges& edges) {
  if (features.dim() != 4 || features.size(1) != (decoder_split_ == 0 ? latent_channels_ : 64)) {
    fail("tiny autoencoder: decode_local_window takes decode_global's features, got " +
         std::string(c10::str(features.sizes())));
  }
  if (inner.h < 1 || inner.w < 1 || inner.y < 0 || inner.x < 0 || inner.y + inner.h > features.size(2) ||
      inner.x + inner.w > features.size(3)) {
    fail("decode_local_window: the wanted rectangle does not lie inside the window " +
         std::string(c10::str(features.sizes())));
  }
  const std::array<bool, 4> edge = {edges.top, edges.left, edges.bottom, edges.right};
  Ring ring;
  ring.side = {inner.y, inner.x, features.size(2) - inner.y - inner.h, features.size(3) - inner.x - inner.w};
  const size_t end = decoder_->size();
  const std::vector<int64_t> need = context_needed(*decoder_, decoder_split_, end);
  for (int s = 0; s < 4; ++s) {
    if (!edge[s] && ring.side[s] < need[0])
      fail("decode_local_window: " + std::to_string(ring.side[s]) + " cells of context on a side inside the image, " +
           "the decoder needs " + std::to_string(need[0]));
  }
  // Cuts `k` from every side inside the image.
  auto cut = [&](const at::Tensor& t, int64_t k) {
    std::array<int64_t, 4> by{};
    for (int s = 0; s < 4; ++s) by[s] = edge[s] ? 0 : k;
    return cut_sides(t, by);
  };
  at::Tensor x = to_network(features);
  auto it = decoder_->begin() + static_cast<std::ptrdiff_t>(decoder_split_);
  for (size_t i = decoder_split_; i < end; ++i, ++it) {
    // Context beyond what the remaining layers need goes first.
    std::array<int64_t, 4> surplus{};
    for (int s = 0; s < 4; ++s) {
      if (edge[s]) continue;
      surplus[s] = ring.side[s] - need[i - decoder_split_];
      ring.side[s] -= surplus[s];
    }
    x = cut_sides(x, surplus);
    const auto& m = decoder_->ptr(i);
    if (m->as<nn::Upsample>()) {
      x = it->forward(x);
      for (auto& r : ring.side) r *= 2;
    } else if (auto* conv = m->as<MixedConv2d>()) {
      x = cut(conv->forward(x), 1);
      for (int s = 0; s < 4; ++s) ring.side[s] -= edge[s] ? 0 : 1;
    } else if (auto* block = m->as<TinyBlock>()) {
      x = block->forward_cut(x, cut);
      for (int s = 0; s < 4; ++s) ring.side[s] -= edge[s] ? 0 : 3;
    } else {
      x = it->forward(x);
    }
  }
  // What is left beyond the rectangle is the image's own pixels on its edges.
  return from_network(cut_sides(x, ring.side));
}

}  // namespace lrf
