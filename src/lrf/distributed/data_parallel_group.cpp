#include "lrf/distributed/c10d_group.h"

#include <chrono>
#include <cstdlib>
#include <future>
#include <map>

#include <torch/csrc/distributed/c10d/PrefixStore.hpp>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"

namespace lrf {
namespace {

using namespace std::chrono_literals;

std::string alive_key(int rank) { return "lrf/alive/" + std::to_string(rank); }
std::string error_key(int rank) { return "lrf/error/" + std::to_string(rank); }

std::vector<uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }
std::string string_of(const std::vector<uint8_t>& b) { return {b.begin(), b.end()}; }

bool is_loopback(const std::string& addr) { return addr == "localhost" || addr.rfind("127.", 0) == 0 || addr == "::1"; }

std::shared_ptr<::gloo::transport::Device> gloo_device(const std::string& master_addr) {
  if (const char* ifname = std::getenv("GLOO_SOCKET_IFNAME"); ifname && *ifname) {
    return c10d::ProcessGroupGloo::createDeviceForInterface(ifname);
  }
  // Every rank on this host: talk over loopback, which needs no resolvable host name.
  if (is_loopback(master_addr)) return c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1");
  return c10d::ProcessGroupGloo::createDefaultDevice();
}

c10d::TCPStoreOptions store_options(const DistributedOptions& o, bool server) {
  c10d::TCPStoreOptions so;
  so.port = static_cast<std::uint16_t>(o.master_port);
  so.isServer = server;
  so.numWorkers = static_cast<size_t>(o.world_size);
  so.waitWorkers = true;
  so.timeout = std::chrono::milliseconds(static_cast<int64_t>(o.timeout_seconds * 1000));
  return so;
}

// The first line of a libtorch / Gloo error (their backtraces follow).
std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

}  // namespace

DataParallelGroup::DataParallelGroup() = default;

std::unique_ptr<DataParallelGroup> join_data_parallel(const DistributedOptions& options, const std::string& job) {
  if (options.world_size <= 1) return std::make_unique<DataParallelGroup>();
  return std::make_unique<DataParallelGroup>(options, job);
}

DataParallelGroup::DataParallelGroup(const DistributedOptions& o, const std::string& job)
    : rank_(o.rank), world_size_(o.world_size), impl_(std::make_unique<Impl>()) {
  impl_->options = o;
  impl_->job = job;
  const std::string where = o.master_addr + ":" + std::to_string(o.master_port);
  log_info(job + ": rank " + std::to_string(o.rank) + " of " + std::to_string(o.world_size) + " joining " + where);
  try {
    impl_->store = c10::make_intrusive<c10d::TCPStore>(o.master_addr, store_options(o, o.rank == 0));
    auto gloo = c10d::ProcessGroupGloo::Options::create(
        std::chrono::milliseconds(static_cast<int64_t>(o.timeout_seconds * 1000)));
    gloo->devices.push_back(gloo_device(o.master_addr));
    impl_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(
        c10::make_intrusive<c10d::PrefixStore>("gloo", impl_->store), o.rank, o.world_size, gloo);
    c10d::TCPStoreOptions pulse = store_options(o, false);
    pulse.waitWorkers = false;
    pulse.numWorkers = c10::nullopt;
    impl_->pulse_store = c10::make_intrusive<c10d::TCPStore>(o.master_addr, pulse);
  } catch (const std::exception& e) {
    fail(job + ": rank " + std::to_string(o.rank) + " of " + std::to_string(o.world_size) +
         " could not join the job at " + where + " within " + std::to_string(static_cast<int>(o.timeout_seconds)) +
         " s (are all ranks started, with the same MASTER_ADDR, MASTER_PORT and WORLD_SIZE?): " +
         first_line(e.what()));
  }
  // The heartbeat: a counter in the store that moves twice a second while this process lives and is not
  // stopped. It runs on its own connection so a collective in progress never delays it.
  auto store = impl_->pulse_store;
  auto stop = impl_->stop;
  const std::string key = alive_key(rank_);
  impl_->pulse = std::thread([store, stop, key] {
    while (!stop->load()) {
      try {
        store->add(key, 1);
      } catch (const std::exception&) {
        return;  // the store is gone: the collectives will say so
      }
      std::this_thread::sleep_for(500ms);
    }
  });
}

DataParallelGroup::~DataParallelGroup() {
  if (!impl_) return;
  *impl_->stop = true;
  if (!impl_->pulse.joinable()) return;
  // After a failure the heartbeat may be blocked on a store that no longer answers: it must not keep the
  // process alive (it owns what it uses). Otherwise it ends within its half-second sleep.
  if (impl_->failed) {
    impl_->pulse.detach();
  } else {
    impl_->pulse.join();
  }
}

std::string DataParallelGroup::prefix() const {
  return distributed() ? "rank " + std::to_string(rank_) + " of " + std::to_string(world_size_) + ": " : "";
}

void DataParallelGroup::sum(std::vector<double>& values) {
  if (!distributed() || values.empty()) return;
  std::vector<at::Tensor> t = {at::tensor(at::ArrayRef<double>(values), at::kDouble)};
  impl_->group->allreduce(t)->wait();
  const at::Tensor& r = t[0];
  for (size_t i = 0; i < values.size(); ++i) values[i] = r[static_cast<int64_t>(i)].item<double>();
}

void DataParallelGroup::sum(const at::Tensor& values) {
  if (!distributed()) return;
  std::vector<at::Tensor> t = {values};
  impl_->group->allreduce(t)->wait();
}

std::string DataParallelGroup::from_main(const std::string& key, const std::string& value) {
  if (!distributed()) return value;
  const std::string k = "lrf/main/" + key;
  if (is_main()) impl_->store->set(k, bytes_of(value));
  return string_of(impl_->store->get(k));
}

void DataParallelGroup::broadcast_from_main(const std::vector<at::Tensor>& tensors) {
  if (!distributed()) return;
  at::NoGradGuard no_grad;
  for (const at::Tensor& t : tensors) {
    std::vector<at::Tensor> buffer = {t.detach().contiguous()};
    impl_->group->broadcast(buffer)->wait();
    if (!buffer[0].is_same(t)) t.detach().copy_(buffer[0]);
  }
}

void DataParallelGroup::barrier() {
  if (!distributed()) return;
  impl_->group->barrier()->wait();
}

void DataParallelGroup::start_together(const std::string& problem) {
  if (!distributed()) {
    if (!problem.empty()) fail(problem);
    return;
  }
  const std::string key = "lrf/startup/";
  impl_->store->set(key + std::to_string(rank_), bytes_of(problem));
  std::vector<double> failed(static_cast<size_t>(world_size_), 0.0);
  failed[static_cast<size_t>(rank_)] = problem.empty() ? 0.0 : 1.0;
  sum(failed);
  std::string message;
  for (int r = 0; r < world_size_; ++r) {
    if (failed[static_cast<size_t>(r)] == 0) continue;
    message += (message.empty() ? "" : "; ") + std::string("rank ") + std::to_string(r) + ": " +
               string_of(impl_->store->get(key + std::to_string(r)));
  }
  if (!message.empty()) fail(impl_->job + ": not started, because " + message);
}

void DataParallelGroup::require_same_as_main(const nlohmann::json& description, const std::string& what) {
  if (!distributed()) return;
  const std::string mine = description.dump();
  const std::string key = "lrf/describe/" + what + "/";
  impl_->store->set(key + std::to_string(rank_), bytes_of(mine));
  const std::string main = string_of(impl_->store->get(key + "0"));
  std::vector<double> differs(static_cast<size_t>(world_size_), 0.0);
  differs[static_cast<size_t>(rank_)] = mine == main ? 0.0 : 1.0;
  sum(differs);
  std::string message;
  // Flattened ("/options/lambda_reg"), so that the message names the very setting that differs.
  const nlohmann::json main_json = nlohmann::json::parse(main).flatten();
  for (int r = 0; r < world_size_; ++r) {
    if (differs[static_cast<size_t>(r)] == 0) continue;
    const nlohmann::json other = nlohmann::json::parse(string_of(impl_->store->get(key + std::to_string(r)))).flatten();
    std::string d = differing_settings(other, main_json);
    if (d.empty()) d = " (settings missing on rank 0)";
    message += "; rank " + std::to_string(r) + " differs from rank 0 in" + d;
  }
  if (!message.empty()) {
    fail(impl_->job + ": the ranks were started with different " + what + " (values given as: that rank vs rank 0)" +
         message + "; every rank must run the same command on the same data");
  }
}

void DataParallelGroup::fail_step(const std::string& where, const std::string& error, const std::string& advice) {
  if (!distributed()) fail(error);
  impl_->failed = true;
  // Ask the store who is gone, on a thread of its own: a store whose host is stopped may not answer.
  struct Finding {
    std::string text;
  };
  auto finding = std::make_shared<std::promise<Finding>>();
  std::future<Finding> answer = finding->get_future();
  auto store = impl_->pulse_store;
  const int me = rank_, world = world_size_;
  std::thread([finding, store, me, world] {
    Finding f;
    try {
      for (int r = 0; r < world; ++r) {
        if (r != me && store->check({error_key(r)})) {
          f.text = "rank " + std::to_string(r) + " failed first: " + string_of(store->get(error_key(r)));
          finding->set_value(f);
          return;
        }
      }
      std::vector<int64_t> before(static_cast<size_t>(world));
      for (int r = 0; r < world; ++r) before[static_cast<size_t>(r)] = store->add(alive_key(r), 0);
      std::this_thread::sleep_for(2500ms);
      std::string silent;
      for (int r = 0; r < world; ++r) {
        if (r != me && store->add(alive_key(r), 0) == before[static_cast<size_t>(r)]) {
          silent += (silent.empty() ? "" : ", ") + std::to_string(r);
        }
      }
      if (!silent.empty()) {
        f.text = "rank " + silent + " stopped responding (no heartbeat for 2.5 s: killed, crashed or stopped)";
      }
    } catch (const std::exception&) {
      f.text = "rank 0, which hosts the job's rendezvous store, is gone (killed or crashed)";
    }
    finding->set_value(f);
  }).detach();
  std::string cause;
  if (answer.wait_for(8s) == std::future_status::ready) {
    cause = answer.get().text;
  } else {
    cause = "rank 0, which hosts the job's rendezvous store, does not answer (stopped or hung)";
  }
  const std::string here = prefix() + where + ": ";
  if (!cause.empty()) fail(here + cause + " [" + first_line(error) + "]" + advice);
  // Nobody else is gone: this rank's own error stops the job; leave it where the others will look.
  try {
    impl_->store->set(error_key(rank_), bytes_of(where + ": " + first_line(error)));
  } catch (const std::exception&) {
  }
  fail(here + error + advice);
}

}  // namespace lrf
