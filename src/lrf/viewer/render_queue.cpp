#include "lrf/viewer/render_queue.h"

#include <utility>

namespace lrf::viewer {

RenderQueue::RenderQueue(size_t max_waiting, size_t max_clients) : max_waiting_(max_waiting), max_clients_(max_clients) {}

RenderQueue::Turn::Turn(Turn&& other) noexcept : queue_(std::exchange(other.queue_, nullptr)), outcome_(other.outcome_) {}

RenderQueue::Turn& RenderQueue::Turn::operator=(Turn&& other) noexcept {
  if (this != &other) {
    if (queue_) queue_->release();
    queue_ = std::exchange(other.queue_, nullptr);
    outcome_ = other.outcome_;
  }
  return *this;
}

RenderQueue::Turn::~Turn() {
  if (queue_) queue_->release();
}

bool RenderQueue::newer_exists(const std::string& client, long long seq) const {
  auto it = clients_.find(client);
  return it != clients_.end() && it->second.latest > seq;
}

void RenderQueue::remember(const std::string& client, long long seq) {
  auto& state = clients_[client];
  if (seq > state.latest) state.latest = seq;
  state.last_seen = ++clock_;
  if (clients_.size() > max_clients_) {
    // Forget the tab seen longest ago (a linear scan: this happens once per new tab beyond the limit).
    auto oldest = clients_.begin();
    for (auto it = clients_.begin(); it != clients_.end(); ++it)
      if (it->second.last_seen < oldest->second.last_seen) oldest = it;
    clients_.erase(oldest);
  }
}

RenderQueue::Turn RenderQueue::acquire(const std::string& client, long long seq) {
  Turn turn;
  std::unique_lock<std::mutex> lock(mutex_);
  if (newer_exists(client, seq)) {
    ++stale_;
    turn.outcome_ = Outcome::stale;
    return turn;
  }
  remember(client, seq);
  if (next_ticket_ - serving_ >= max_waiting_) {
    turn.outcome_ = Outcome::busy;
    return turn;
  }
  const uint64_t ticket = next_ticket_++;
  turn_changed_.wait(lock, [&] { return serving_ == ticket; });
  if (newer_exists(client, seq)) {
    // Pass the turn on without rendering.
    ++serving_;
    ++stale_;
    turn_changed_.notify_all();
    turn.outcome_ = Outcome::stale;
    return turn;
  }
  turn.queue_ = this;
  turn.outcome_ = Outcome::granted;
  return turn;
}

void RenderQueue::release() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++serving_;
  }
  turn_changed_.notify_all();
}

size_t RenderQueue::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<size_t>(next_ticket_ - serving_);
}

size_t RenderQueue::stale_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stale_;
}

}  // namespace lrf::viewer
