#include "lrf/distributed/gradient_averager.h"

#include <ATen/ATen.h>

#include "lrf/distributed/c10d_group.h"

namespace lrf {

namespace {
// PyTorch DDP's defaults: a small first bucket so that communication starts early in the backward.
constexpr int64_t kFirstBucketBytes = 1 << 20;
constexpr int64_t kBucketBytes = 25 << 20;
}  // namespace

struct GradientAverager::State {
  struct Bucket {
    std::vector<size_t> params;
    std::vector<int64_t> offsets;
    int64_t used_flags_at = -1;  // the last bucket: where its per-parameter "used" counts start
    at::Tensor flat;
    size_t pending = 0;
    c10::intrusive_ptr<c10d::Work> work;
  };
  DataParallelGroup* group = nullptr;
  std::vector<at::Tensor> params;
  std::vector<Bucket> buckets;
  std::vector<size_t> bucket_of, slot_of;
  std::vector<bool> used;
  size_t next_launch = 0;
  bool active = false;

  void launch_ready_buckets(bool all) {
    // Buckets go out in the same order on every rank (collectives must match); the last one waits for
    // finish_step(), which adds the "used" counts.
    while (next_launch < buckets.size()) {
      Bucket& b = buckets[next_launch];
      const bool last = next_launch + 1 == buckets.size();
      if (!all && (b.pending > 0 || last)) return;
      std::vector<at::Tensor> t = {b.flat};
      b.work = group->impl().group->allreduce(t);
      ++next_launch;
    }
  }

  void on_gradient(size_t i, const at::Tensor& grad) {
    if (!active) return;
    Bucket& b = buckets[bucket_of[i]];
    const size_t s = slot_of[i];
    b.flat.narrow(0, b.offsets[s], params[i].numel()).copy_(grad.reshape(-1));
    used[i] = true;
    --b.pending;
    launch_ready_buckets(false);
  }
};

GradientAverager::GradientAverager(DataParallelGroup& group, std::vector<at::Tensor> parameters)
    : state_(std::make_shared<State>()) {
  if (!group.distributed()) return;
  State& s = *state_;
  s.group = &group;
  s.params = std::move(parameters);
  const size_t n = s.params.size();
  s.bucket_of.resize(n);
  s.slot_of.resize(n);
  s.used.assign(n, false);
  int64_t bytes = 0;
  for (size_t k = n; k-- > 0;) {
    const at::Tensor& p = s.params[k];
    const int64_t size = p.numel() * static_cast<int64_t>(p.element_size());
    const int64_t cap = s.buckets.size() <= 1 ? kFirstBucketBytes : kBucketBytes;
    if (s.buckets.empty() || (bytes > 0 && bytes + size > cap)) {
      s.buckets.emplace_back();
      bytes = 0;
    }
    s.bucket_of[k] = s.buckets.size() - 1;
    s.slot_of[k] = s.buckets.back().params.size();
    s.buckets.back().params.push_back(k);
    bytes += size;
  }
  for (auto& b : s.buckets) {
    int64_t elements = 0;
    for (size_t k : b.params) {
      b.offsets.push_back(elements);
      elements += s.params[k].numel();
    }
    if (&b == &s.buckets.back()) {
      b.used_flags_at = elements;
      elements += static_cast<int64_t>(n);
    }
    b.flat = at::zeros({elements}, s.params.front().options().requires_grad(false));
  }
  for (size_t k = 0; k < n; ++k) {
    std::weak_ptr<State> weak = state_;
    s.params[k].register_hook([weak, k](const at::Tensor& grad) {
      if (auto state = weak.lock()) state->on_gradient(k, grad);
    });
  }
}

GradientAverager::~GradientAverager() = default;

int GradientAverager::buckets() const { return static_cast<int>(state_->buckets.size()); }

void GradientAverager::begin_step() {
  State& s = *state_;
  if (!s.group) return;
  for (auto& b : s.buckets) {
    b.pending = b.params.size();
    b.work.reset();
  }
  s.used.assign(s.params.size(), false);
  s.next_launch = 0;
  s.active = true;
}

void GradientAverager::finish_step() {
  State& s = *state_;
  if (!s.group) return;
  s.active = false;
  // Parameters this rank's loss did not reach contribute zeros (and a "used" count of 0).
  for (size_t k = 0; k < s.params.size(); ++k) {
    State::Bucket& b = s.buckets[s.bucket_of[k]];
    if (!s.used[k]) b.flat.narrow(0, b.offsets[s.slot_of[k]], s.params[k].numel()).zero_();
  }
  State::Bucket& last = s.buckets.back();
  at::Tensor flags = last.flat.narrow(0, last.used_flags_at, static_cast<int64_t>(s.params.size()));
  for (size_t k = 0; k < s.params.size(); ++k) flags[static_cast<int64_t>(k)].fill_(s.used[k] ? 1.0 : 0.0);
  s.launch_ready_buckets(true);
  for (auto& b : s.buckets) b.work->wait();
  const double ranks = s.group->world_size();
  at::NoGradGuard no_grad;
  for (size_t k = 0; k < s.params.size(); ++k) {
    at::Tensor& grad = s.params[k].mutable_grad();
    if (flags[static_cast<int64_t>(k)].item<double>() == 0) {
      grad = at::Tensor();
      continue;
    }
    const State::Bucket& b = s.buckets[s.bucket_of[k]];
    grad = b.flat.narrow(0, b.offsets[s.slot_of[k]], s.params[k].numel()).div(ranks).view(s.params[k].sizes());
  }
}

}  // namespace lrf
