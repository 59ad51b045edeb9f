// Load test of lrf serve's server on loopback: a trained field served in-process, then C concurrent
// clients requesting frames as the viewer page does (three small frames while "moving", then one at full
// resolution) for a bounded time, after one client alone for the same time (the baseline, measured back
// to back in the same run). While the C clients run, another thread keeps sending malformed requests
// (non-finite and absurd poses, garbage bytes, oversized URIs and headers, bodies, unknown paths). Prints
// latency percentiles, frame rates, the statuses seen and their ratios; exits 1 when any well-formed
// request failed, any malformed one was not refused, or the server stops answering afterwards.
//
// usage: bench_serve RUN [--clients C] [--seconds S] [--decoder DEC] [--threads N]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

#include "lrf/core/allocator.h"
#include "lrf/core/log.h"
#include "lrf/core/threads.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/field_frames.h"
#include "lrf/viewer/viewer_server.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Phase {
  std::vector<double> latencies_ms;  // of 200 answers
  std::map<int, long> statuses;     // -1: no answer (connection error)
  long low = 0, full = 0;
  double seconds = 0;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(std::ceil(q * double(v.size())) - 1))];
}

std::string numbers(const double* x, int n) {
  std::ostringstream s;
  s.precision(17);
  for (int i = 0; i < n; ++i) s << (i ? "," : "") << x[i];
  return s.str();
}

// A frame request near view `view` of the scene: turned by `angle` about the camera's vertical axis.
std::string frame_path(const lrf::Camera& base, const std::string& client, long seq, double angle, bool full, int multiple) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  lrf::Camera c = base;
  const Eigen::Vector3d centre = base.center();
  c.R = turn * base.R;
  c.t = -c.R * centre;
  if (!full) {
    const int w = std::max(multiple, (base.width / 2) / multiple * multiple);
    const int h = std::max(multiple, (base.height / 2) / multiple * multiple);
    c = c.resized(w, h);
  }
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = c.R;
  std::ostringstream q;
  q.precision(17);
  q << "/api/frame?client=" << client << "&seq=" << seq << "&w=" << c.width << "&h=" << c.height << "&fx=" << c.fx
    << "&fy=" << c.fy << "&cx=" << c.cx << "&cy=" << c.cy << "&r=" << numbers(R.data(), 9) << "&t=" << numbers(c.t.data(), 3);
  return q.str();
}

// `name` prefixes the clients' ids: a phase must not reuse another's ids, whose higher request numbers would
// make its first requests stale.
Phase run_clients(const std::string& name, int port, int clients, double seconds, const std::vector<lrf::Camera>& views,
                  int multiple) {
  Phase phase;
  std::mutex mutex;
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration<double>(seconds);
  std::vector<std::thread> threads;
  for (int k = 0; k < clients; ++k) {
    threads.emplace_back([&, k] {
      httplib::Client client("127.0.0.1", port);
      client.set_read_timeout(120, 0);
      client.set_keep_alive(true);
      const std::string id = name + std::to_string(k);
      Phase mine;
      for (long seq = 1; Clock::now() < end; ++seq) {
        const bool full = seq % 4 == 0;
        const auto& view = views[static_cast<size_t>((k + seq / 4) % static_cast<long>(views.size()))];
        const std::string path = frame_path(view, id, seq, 0.02 * double(seq % 4), full, multiple);
        const auto t0 = Clock::now();
        auto res = client.Get(path.c_str());
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        const int status = res ? res->status : -1;
        ++mine.statuses[status];
        if (status == 200) {
          mine.latencies_ms.push_back(ms);
          ++(full ? mine.full : mine.low);
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      phase.latencies_ms.insert(phase.latencies_ms.end(), mine.latencies_ms.begin(), mine.latencies_ms.end());
      for (auto [s, n] : mine.statuses) phase.statuses[s] += n;
      phase.low += mine.low;
      phase.full += mine.full;
    });
  }
  for (auto& t : threads) t.join();
  phase.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return phase;
}

std::string raw_exchange(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string answer;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    timeval tv{10, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    ::shutdown(fd, SHUT_WR);
    char buf[1024];
    ssize_t n;
    while (answer.size() < 1024 && (n = ::recv(fd, buf, sizeof buf, 0)) > 0) answer.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);
  return answer;
}

// Sends malformed requests until `stop`; counts those that were not refused (a 2xx answer).
struct Abuse {
  long sent = 0, accepted = 0;
};
Abuse abuse(int port, const lrf::Camera& view, const std::atomic<bool>& stop) {
  Abuse a;
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(30, 0);
  const std::string good = frame_path(view, "abuser", 1, 0, true, 8);
  auto with = [&](const std::string& key, const std::string& value) {
    std::string q = good;
    const size_t s = q.find("&" + key + "=") + key.size() + 2;
    return q.replace(s, q.find('&', s) == std::string::npos ? std::string::npos : q.find('&', s) - s, value);
  };
  const std::vector<std::string> bad_paths = {
      with("fx", "NaN"), with("t", "0,0,1e300"), with("t", "1e9,0,0"), with("r", "1,0,0,0,1,0,0,0,-1"), with("w", "99999"),
      with("seq", "-5"), "/api/frame?client=abuser", "/../../etc/passwd", "/api/frame/../../secret", "/" + std::string(9000, 'x')};
  const std::vector<std::string> raw = {std::string("\x16\x03\x01\x02\x00garbage\r\n\r\n", 16), "GET\r\n\r\n",
                                        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX: " + std::string(20000, 'h') + "\r\n\r\n",
                                        "POST /api/frame HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 99999999\r\n\r\nabc"};
  for (size_t k = 0; !stop; ++k) {
    if (k % 3 == 2) {
      const std::string answer = raw_exchange(port, raw[(k / 3) % raw.size()]);
      if (answer.rfind("HTTP/1.1 2", 0) == 0) ++a.accepted;
    } else {
      auto res = client.Get(bad_paths[k % bad_paths.size()].c_str());
      if (res && res->status < 300) ++a.accepted;
    }
    ++a.sent;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return a;
}

void print_phase(const char* name, int clients, const Phase& p) {
  long total = 0;
  std::string statuses;
  for (auto [s, n] : p.statuses) {
    total += n;
    statuses += " " + std::to_string(s) + ":" + std::to_string(n);
  }
  std::printf("%-10s clients %2d  frames %5zu (%ld low, %ld full) in %.1f s = %6.2f frames/s  latency ms p50 %7.1f  p90 %7.1f  "
              "p99 %7.1f  max %7.1f  statuses%s\n",
              name, clients, p.latencies_ms.size(), p.low, p.full, p.seconds, double(p.latencies_ms.size()) / p.seconds,
              percentile(p.latencies_ms, 0.5), percentile(p.latencies_ms, 0.9), percentile(p.latencies_ms, 0.99),
              percentile(p.latencies_ms, 1.0), statuses.c_str());
}

int usage() {
  std::fprintf(stderr, "usage: bench_serve RUN [--clients C] [--seconds S] [--decoder DEC] [--threads N]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();
  if (argc < 2) return usage();
  const std::string run = argv[1];
  std::string decoder;
  int clients = 8, threads = 0;
  double seconds = 20;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    if (a == "--clients") clients = std::max(1, std::atoi(argv[++i]));
    else if (a == "--seconds") seconds = std::max(1.0, std::atof(argv[++i]));
    else if (a == "--decoder") decoder = argv[++i];
    else if (a == "--threads") threads = std::atoi(argv[++i]);
    else return usage();
  }
  lrf::set_log_mode(lrf::LogMode::quiet);
  lrf::set_thread_count(threads);
  auto frames = lrf::open_field_frames(run, decoder);
  const std::string description = frames->describe();
  const int multiple = frames->size_multiple();
  std::vector<lrf::Camera> views;
  for (int i : frames->scene().test_indices) views.push_back(frames->scene().views[static_cast<size_t>(i)].camera);
  if (views.empty()) views.push_back(frames->scene().views.front().camera);
  lrf::viewer::ServeOptions options;
  options.port = 0;
  lrf::viewer::ViewerServer server(std::move(frames), options);
  const int port = server.start();
  std::printf("bench_serve: %s\nserver on 127.0.0.1:%d; frames %dx%d (full) and %dx%d (low); %.0f s per phase\n",
              description.c_str(), port, views[0].width, views[0].height,
              std::max(multiple, (views[0].width / 2) / multiple * multiple),
              std::max(multiple, (views[0].height / 2) / multiple * multiple), seconds);

  const Phase one = run_clients("baseline", port, 1, seconds, views, multiple);
  print_phase("baseline", 1, one);
  std::atomic<bool> stop{false};
  Abuse abused;
  std::thread abuser([&] { abused = abuse(port, views[0], stop); });
  const Phase many = run_clients("load", port, clients, seconds, views, multiple);
  stop = true;
  abuser.join();
  print_phase("load", clients, many);
  std::printf("ratios (load / baseline): frames/s %.2f, p50 latency %.2f, p99 latency %.2f\n",
              (double(many.latencies_ms.size()) / many.seconds) / (double(one.latencies_ms.size()) / one.seconds),
              percentile(many.latencies_ms, 0.5) / percentile(one.latencies_ms, 0.5),
              percentile(many.latencies_ms, 0.99) / percentile(one.latencies_ms, 0.99));
  std::printf("malformed requests during the load: %ld sent, %ld not refused\n", abused.sent, abused.accepted);

  // Still answering afterwards.
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(120, 0);
  auto after = client.Get(frame_path(views[0], "after", 1, 0, true, multiple).c_str());
  const bool alive = after && after->status == 200 && after->get_header_value("Content-Type") == "image/jpeg";
  std::printf("after the load and the malformed requests: %s\n", alive ? "a frame, status 200" : "NO ANSWER");
  const auto stats = server.stats();
  std::printf("server: %ld frames rendered, %ld stale dropped, %ld busy, %ld bad requests refused\n", stats.frames,
              stats.stale, stats.busy, stats.rejected);
  long failures = 0;
  for (const Phase* p : {&one, &many})
    for (auto [s, n] : p->statuses)
      if (s != 200) failures += n;
  server.stop();
  const bool ok = failures == 0 && abused.accepted == 0 && alive;
  std::printf("%s\n", ok ? "OK: no errors" : "FAILED");
  return ok ? 0 : 1;
}
