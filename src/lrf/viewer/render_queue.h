#pragma once
// Who renders next. Frames are rendered one at a time (a frame already uses every core), in the order the
// requests arrived, so that no browser tab starves the others. A tab's newer request makes its older
// ones stale: a stale request that is still waiting gives up its turn without rendering, so a moving
// camera never queues behind frames nobody will look at.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace lrf::viewer {

class RenderQueue {
 public:
  // At most `max_waiting` requests wait at once (further ones are turned away as busy); the newest
  // request numbers of at most `max_clients` tabs are remembered (the least recently seen are forgotten).
  explicit RenderQueue(size_t max_waiting = 64, size_t max_clients = 1024);

  enum class Outcome { granted, stale, busy };

  // The right to render, held until destruction (then the next request in line goes).
  class Turn {
   public:
    Turn() = default;
    Turn(Turn&& other) noexcept;
    Turn& operator=(Turn&& other) noexcept;
    ~Turn();
    Outcome outcome() const { return outcome_; }
    bool granted() const { return outcome_ == Outcome::granted; }

   private:
    friend class RenderQueue;
    RenderQueue* queue_ = nullptr;  // set while holding the turn
    Outcome outcome_ = Outcome::stale;
  };

  // Waits for the turn of request `seq` of tab `client`. Returns at once as stale when the tab has sent a
  // newer request, as busy when too many wait; after waiting, as stale when a newer one arrived meanwhile.
  Turn acquire(const std::string& client, long long seq);

  // Requests waiting or rendering now.
  size_t pending() const;
  size_t stale_count() const;

 private:
  void release();
  bool newer_exists(const std::string& client, long long seq) const;
  void remember(const std::string& client, long long seq);

  struct ClientState {
    long long latest = -1;
    uint64_t last_seen = 0;
  };
  mutable std::mutex mutex_;
  std::condition_variable turn_changed_;
  uint64_t next_ticket_ = 0, serving_ = 0, clock_ = 0;
  size_t max_waiting_, max_clients_, stale_ = 0;
  std::map<std::string, ClientState> clients_;
};

}  // namespace lrf::viewer
