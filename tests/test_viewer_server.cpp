// lrf serve's server: request validation, stale-request dropping, and the HTTP server itself on a tiny
// field (its page, scene, frames, and every kind of bad request, after which it still answers).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "field_helpers.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/field_frames.h"
#include "lrf/viewer/frame_request.h"
#include "lrf/viewer/render_queue.h"
#include "lrf/viewer/viewer_server.h"
#include "test_helpers.h"

namespace v = lrf::viewer;

namespace {

std::string numbers(const std::vector<double>& xs) {
  std::ostringstream s;
  s.precision(17);
  for (size_t i = 0; i < xs.size(); ++i) s << (i ? "," : "") << xs[i];
  return s.str();
}

// A valid request for the identity pose 2 units behind the origin, 64x48.
v::QueryParams good_params() {
  return {{"client", "tab-1"}, {"seq", "7"}, {"w", "64"}, {"h", "48"}, {"fx", "60"}, {"fy", "60"},
          {"cx", "32"}, {"cy", "24"}, {"r", numbers({1, 0, 0, 0, 1, 0, 0, 0, 1})}, {"t", "0,0,2"}};
}

v::ViewLimits limits(int multiple = 1) {
  v::ViewLimits l;
  l.center = Eigen::Vector3d::Zero();
  l.radius = 1;
  l.size_multiple = multiple;
  l.max_side = 1024;
  return l;
}

// The error message parse_frame_request gives with `key` set to `value` ("" when accepted).
std::string error_with(const std::string& key, const std::string& value, int multiple = 1) {
  auto p = good_params();
  p.erase(key);
  p.emplace(key, value);
  return lrf::test::error_of([&] { v::parse_frame_request(p, limits(multiple)); });
}

}  // namespace

TEST(ViewerRequest, ParsesAGoodRequest) {
  auto r = v::parse_frame_request(good_params(), limits());
  EXPECT_EQ(r.client, "tab-1");
  EXPECT_EQ(r.seq, 7);
  EXPECT_EQ(r.camera.width, 64);
  EXPECT_EQ(r.camera.height, 48);
  EXPECT_DOUBLE_EQ(r.camera.fx, 60);
  EXPECT_LT((r.camera.center() - Eigen::Vector3d(0, 0, -2)).norm(), 1e-12);
  // A browser's float rounding of a rotation is accepted and cleaned up.
  const double a = 0.3;
  auto p = good_params();
  p.erase("r");
  p.emplace("r", numbers({std::cos(a) + 1e-6, 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)}));
  r = v::parse_frame_request(p, limits());
  EXPECT_LT((r.camera.R * r.camera.R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(ViewerRequest, RefusesBadValues) {
  // Each case: (parameter, value, a word the message must contain).
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"fx", "nan", "not a decimal number"},
      {"fx", "NaN", "not a decimal number"},
      {"t", "0,0,inf", "not a decimal number"},
      {"cx", "1e999", "not a finite number"},
      {"cx", "0x10", "not a decimal number"},
      {"cy", "12abc", "not a decimal number"},
      {"cy", "1.2.3", "not a finite number"},
      {"cy", "", "not a number"},
      {"fy", std::string(100, '1'), "not a number"},
      {"w", "0", "whole number of pixels"},
      {"w", "-64", "whole number of pixels"},
      {"w", "64.5", "whole number of pixels"},
      {"w", "100000", "whole number of pixels"},
      {"fx", "0", "field of view"},
      {"fx", "-60", "field of view"},
      {"fx", "1e9", "field of view"},
      {"cx", "1000", "principal point"},
      {"r", numbers({2, 0, 0, 0, 2, 0, 0, 0, 2}), "not a rotation"},
      {"r", numbers({-1, 0, 0, 0, 1, 0, 0, 0, 1}), "not a rotation"},  // a reflection
      {"r", numbers({0, 0, 0, 0, 0, 0, 0, 0, 0}), "not a rotation"},
      {"r", numbers({1, 0, 0, 0, 1, 0, 0, 0}), "9 comma-separated"},
      {"r", numbers({1, 0, 0, 0, 1, 0, 0, 0, 1, 0}), "9 comma-separated"},
      {"t", "0,0,1e6", "times the scene's radius"},
      {"t", "0,0", "3 comma-separated"},
      {"seq", "-1", "'seq'"},
      {"seq", "1.5", "'seq'"},
      {"seq", "1e300", "'seq'"},
      {"client", "", "'client'"},
      {"client", "a b", "'client'"},
      {"client", "<script>", "'client'"},
      {"client", std::string(65, 'a'), "'client'"},
  };
  for (const auto& [key, value, word] : cases) {
    const std::string e = error_with(key, value);
    EXPECT_NE(e.find(word), std::string::npos) << key << "=" << value << " gave: '" << e << "'";
  }
  EXPECT_NE(error_with("w", "60", 8).find("multiple of 8"), std::string::npos);
  auto missing = good_params();
  missing.erase("t");
  EXPECT_NE(lrf::test::error_of([&] { v::parse_frame_request(missing, limits()); }).find("'t' is missing"), std::string::npos);
  auto twice = good_params();
  twice.emplace("w", "64");
  EXPECT_NE(lrf::test::error_of([&] { v::parse_frame_request(twice, limits()); }).find("2 times"), std::string::npos);
  auto extra = good_params();
  extra.emplace("file", "/etc/passwd");
  EXPECT_NE(lrf::test::error_of([&] { v::parse_frame_request(extra, limits()); }).find("unknown parameter"), std::string::npos);
}

TEST(ViewerQueue, DropsStaleRequestsAndServesInOrder) {
  v::RenderQueue queue(3);
  auto first = queue.acquire("a", 1);
  ASSERT_TRUE(first.granted());
  // While "a" renders, tab "b" sends two frames and tab "c" one; b's first goes stale when its second arrives.
  // A stale waiter and the next granted one wake together, so the order in which their threads record is
  // not the order of service; what shows the order of service is how many stale requests had been
  // resolved when a granted turn began.
  std::map<std::string, std::string> outcome;
  std::mutex outcome_mutex;
  auto request = [&](const std::string& client, long long seq) {
    auto turn = queue.acquire(client, seq);
    std::string what = turn.granted() ? "granted after " + std::to_string(queue.stale_count()) + " stale"
                       : turn.outcome() == v::RenderQueue::Outcome::stale ? "stale"
                                                                           : "busy";
    std::lock_guard<std::mutex> lock(outcome_mutex);
    outcome[client + std::to_string(seq)] = what;
  };
  std::thread b1(request, "b", 1);
  while (queue.pending() < 2) std::this_thread::yield();
  std::thread c1(request, "c", 1);
  while (queue.pending() < 3) std::this_thread::yield();
  std::thread b2(request, "b", 2);
  // The queue holds 3 (a rendering, b1, c1 waiting): b2 is turned away as busy, yet it still makes b1 stale.
  b2.join();
  EXPECT_EQ(outcome.at("b2"), "busy");
  // An older request arriving after a newer one is stale at once.
  EXPECT_EQ(queue.acquire("b", 0).outcome(), v::RenderQueue::Outcome::stale);
  first = v::RenderQueue::Turn();  // a finishes
  b1.join();
  c1.join();
  ASSERT_EQ(outcome.size(), 3u);
  EXPECT_EQ(outcome.at("b1"), "stale");
  // b1 was queued before c1, so it was resolved (as stale) before c1's turn began: b0 and b1 make 2.
  EXPECT_EQ(outcome.at("c1"), "granted after 2 stale");
  EXPECT_EQ(queue.pending(), 0u);
  EXPECT_EQ(queue.stale_count(), 2u);
}

namespace {

// Sends raw bytes to the server and returns what it answers (up to 4 KiB; "" when it closes). With
// `close_write` the socket is half-closed after sending, which cpp-httplib sometimes answers by closing it
// unanswered: a test that expects an answer sends "Connection: close" and keeps it open instead.
// A connection to the server on the loopback address (-1 when it cannot connect).
int connect_to(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::string raw_exchange(int port, const std::string& bytes, bool close_write = true) {
  const int fd = connect_to(port);
  if (fd < 0) return "connect failed";
  timeval tv{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  if (close_write) ::shutdown(fd, SHUT_WR);
  std::string answer;
  char buf[4096];
  ssize_t n;
  while (answer.size() < 4096 && (n = ::recv(fd, buf, sizeof buf, 0)) > 0) answer.append(buf, static_cast<size_t>(n));
  ::close(fd);
  return answer;
}

std::string frame_query(const nlohmann::json& view, const std::string& client, int seq, double shift = 0) {
  std::vector<double> R = view["R"].get<std::vector<double>>(), t = view["t"].get<std::vector<double>>();
  t[0] += shift;
  std::ostringstream q;
  q.precision(17);
  q << "/api/frame?client=" << client << "&seq=" << seq << "&w=" << view["width"] << "&h=" << view["height"]
    << "&fx=" << view["fx"].get<double>() << "&fy=" << view["fy"].get<double>() << "&cx=" << view["cx"].get<double>()
    << "&cy=" << view["cy"].get<double>() << "&r=" << numbers(R) << "&t=" << numbers(t);
  return q.str();
}

// `query` with parameter `key`'s value replaced.
std::string with_param(std::string query, const std::string& key, const std::string& value) {
  const size_t start = query.find("&" + key + "=") + key.size() + 2;
  query.replace(start, query.find('&', start) - start, value);
  return query;
}

}  // namespace

TEST(ViewerServer, ServesPageSceneAndFramesAndRefusesTheRest) {
  const std::string field = lrf::test::tiny_field("rgb");
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(field), options);
  const int port = server.start();
  ASSERT_GT(port, 0);
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(30, 0);

  auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("viewer.js"), std::string::npos);
  EXPECT_EQ(page->get_header_value("Content-Type"), "text/html; charset=utf-8");
  auto js = client.Get("/viewer.js");
  ASSERT_TRUE(js);
  EXPECT_EQ(js->status, 200);
  EXPECT_NE(js->body.find("lrfViewer"), std::string::npos);

  auto scene_res = client.Get("/api/scene");
  ASSERT_TRUE(scene_res);
  ASSERT_EQ(scene_res->status, 200);
  const auto scene = nlohmann::json::parse(scene_res->body);
  EXPECT_EQ(scene["space"], "rgb");
  ASSERT_EQ(scene["views"].size(), 8u);
  EXPECT_EQ(scene["views"][0]["split"], "test");
  EXPECT_EQ(scene["views"][1]["split"], "train");

  // A frame of view 0 is that view's render.
  const auto& view = scene["views"][0];
  auto frame = client.Get(frame_query(view, "t1", 1).c_str());
  ASSERT_TRUE(frame);
  ASSERT_EQ(frame->status, 200) << frame->body;
  EXPECT_EQ(frame->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(frame->get_header_value("X-Lrf-Seq"), "1");
  const std::vector<uchar> bytes(frame->body.begin(), frame->body.end());
  const cv::Mat image = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(image.size(), cv::Size(64, 48));
  // An older request of the same tab after a newer one: 204, nothing rendered.
  auto old = client.Get(frame_query(view, "t1", 0).c_str());
  ASSERT_TRUE(old);
  EXPECT_EQ(old->status, 204);

  // Bad requests: each gets its status and a JSON error, none reaches the renderer.
  const std::vector<std::pair<std::string, int>> bad = {
      {with_param(frame_query(view, "t1", 5), "fx", "NaN"), 400},
      {frame_query(view, "t1", 6, 1e9), 400},
      {"/api/frame?client=t1&seq=9", 400},
      {"/etc/passwd", 404},
      {"/../CMakeLists.txt", 404},
      {"/%2e%2e/%2e%2e/etc/passwd", 404},
      {"/viewer.js/..%2f..%2fetc%2fpasswd", 404},
      {"/api/frame/../../x", 404},
      {"/" + std::string(9000, 'a'), 414},
  };
  for (const auto& [path, status] : bad) {
    auto res = client.Get(path.c_str());
    ASSERT_TRUE(res) << path.substr(0, 80);
    EXPECT_EQ(res->status, status) << path.substr(0, 80);
    if (res->status != 414) {
      EXPECT_NE(res->body.find("\"error\""), std::string::npos) << path.substr(0, 80);
    }
  }
  auto post = client.Post("/api/frame", std::string(100, 'x'), "text/plain");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  auto big = client.Post("/", std::string(1 << 20, 'x'), "text/plain");
  EXPECT_TRUE(!big || big->status == 413 || big->status == 405);
  httplib::Headers evil = {{"Host", "evil.example:80"}};
  auto rebinding = client.Get("/api/scene", evil);
  ASSERT_TRUE(rebinding);
  EXPECT_EQ(rebinding->status, 403);

  // Garbage on the socket: an error or a closed connection, never a crash.
  for (const std::string& junk : {std::string("\x00\x01\x02garbage\r\n\r\n", 14), std::string("GET\r\n\r\n"),
                                  std::string("GET /api/frame HTTP/1.1\r\nHost: 127.0.0.1\r\n") + std::string(20000, 'h') + "\r\n\r\n",
                                  std::string("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 99999999999\r\n\r\nabc")}) {
    const std::string answer = raw_exchange(port, junk);
    EXPECT_TRUE(answer.empty() || answer.rfind("HTTP/1.1 4", 0) == 0) << answer.substr(0, 60);
  }

  // Still answering, with a different frame for a moved camera.
  auto again = client.Get(frame_query(view, "t2", 1, 0.5).c_str());
  ASSERT_TRUE(again);
  ASSERT_EQ(again->status, 200);
  EXPECT_NE(again->body, frame->body);
  const auto stats = server.stats();
  EXPECT_EQ(stats.frames, 2);
  EXPECT_GE(stats.rejected, 3);
  server.stop();
}

// Two Host headers (one of them foreign) used to get 200: the check read one, a proxy may read the other.
TEST(ViewerServer, RefusesRepeatedHostHeaders) {
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(lrf::test::tiny_field("rgb")), options);
  const int port = server.start();
  for (const std::string hosts : {"Host: 127.0.0.1\r\nHost: evil.example\r\n", "Host: evil.example\r\nHost: 127.0.0.1\r\n",
                                   "Host: 127.0.0.1\r\nhost: 127.0.0.1\r\n"}) {
    const std::string answer =
        raw_exchange(port, "GET /api/scene HTTP/1.1\r\n" + hosts + "Connection: close\r\n\r\n", false);
    EXPECT_EQ(answer.rfind("HTTP/1.1 400", 0), 0u) << hosts << answer.substr(0, 60);
  }
  const std::string one =
      raw_exchange(port, "GET /api/scene HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n", false);
  EXPECT_EQ(one.rfind("HTTP/1.1 200", 0), 0u) << one.substr(0, 60);
}

namespace {

// This process's resident memory, in MB (the server runs inside it).
double resident_mb() {
  long pages = 0, resident = 0;
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
  std::fclose(f);
  return static_cast<double>(resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / 1e6;
}

// Sends `head` and then up to `mb` MB of `filler` as fast as the server takes it; returns how many MB it
// took before it closed the connection.
double stream_into(int port, const std::string& head, char filler, int mb) {
  const int fd = connect_to(port);
  if (fd < 0) return -1;
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  ::send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  const std::string chunk(1 << 20, filler);
  int sent = 0;
  for (; sent < mb; ++sent)
    if (::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(chunk.size())) break;
  ::close(fd);
  return sent;
}

}  // namespace

// Connections that send half a request, or none, used to hold a connection thread each until they timed
// out: 200 of them made a page's request wait 12 s. Heads are now read by one thread that waits on all
// connections, so the request is answered at once; 600 of them (past the 512 the server keeps) cannot
// lock it out either: the oldest are closed to make room.
TEST(ViewerServer, HalfOpenConnectionsHoldNoThreadAndCannotLockOthersOut) {
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(lrf::test::tiny_field("rgb")), options);
  const int port = server.start();
  // Both ends of every connection live in this process: 600 of them need 1200 descriptors, so the soft
  // limit is raised as far as the hard one allows, and fewer connections are made below that.
  rlimit files{};
  ::getrlimit(RLIMIT_NOFILE, &files);
  files.rlim_cur = std::max(files.rlim_cur, std::min<rlim_t>(files.rlim_max, 4096));
  ::setrlimit(RLIMIT_NOFILE, &files);
  const int connections = static_cast<int>(std::min<rlim_t>(600, (files.rlim_cur - 200) / 2));
  std::vector<int> idle;
  for (int k = 0; k < connections; ++k) {
    const int fd = connect_to(port);
    ASSERT_GE(fd, 0);
    const std::string half = k % 2 ? "GET /api/scene HTTP/1.1\r\nHost: 127" : "";  // or nothing at all
    ::send(fd, half.data(), half.size(), MSG_NOSIGNAL);
    idle.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the server has taken them in
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(30, 0);
  const auto start = std::chrono::steady_clock::now();
  auto res = client.Get("/api/scene");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (int fd : idle) ::close(fd);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  // At once, not after the 2 s a half-sent head may take: a second leaves room for a loaded machine.
  EXPECT_LT(seconds, 1.0) << "a request waited behind " << connections << " half-open connections";
  std::printf("viewer: a request behind %d half-open connections took %.3f s\n", connections, seconds);
}

// A 1 GB POST took the server from 0.77 to 1.75 GB and a 300 MB request line to 2.8 GB: requests were read
// whole before they were refused. Now the server reads at most its 16 KiB head limit of either before it
// answers and closes: streaming 256 MB at it moves the process's memory by far less than that.
TEST(ViewerServer, OversizedRequestsAreRefusedBeforeTheyAreRead) {
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(lrf::test::tiny_field("rgb")), options);
  const int port = server.start();
  const double before = resident_mb();
  const double body_mb = stream_into(port, "POST /api/frame HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1000000000\r\n\r\n", 'x', 256);
  const double url_mb = stream_into(port, "GET /", 'a', 256);
  const double header_mb = stream_into(port, "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ", 'h', 256);
  const double grown = resident_mb() - before;
  std::printf("viewer: the server took %.0f, %.0f and %.0f MB of a body, a URL and a header; memory grew %.1f MB\n",
              body_mb, url_mb, header_mb, grown);
  // What the kernel buffers before the server closes is a few MB at most; the server's own share is 16 KiB.
  EXPECT_LT(body_mb, 64);
  EXPECT_LT(url_mb, 64);
  EXPECT_LT(header_mb, 64);
  EXPECT_LT(grown, 32) << "the server kept what it was sent";
  // The refusals themselves, as a client that waits for them sees them.
  EXPECT_EQ(raw_exchange(port, "GET /" + std::string(20000, 'a') + " HTTP/1.1\r\n\r\n", false).rfind("HTTP/1.1 414", 0), 0u);
  EXPECT_EQ(raw_exchange(port, "POST / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5\r\n\r\nhello", false)
                .rfind("HTTP/1.1 405", 0),
            0u);
  EXPECT_EQ(raw_exchange(port, "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX: " + std::string(20000, 'h') + "\r\n\r\n", false)
                .rfind("HTTP/1.1 431", 0),
            0u);
  // And it still serves.
  httplib::Client client("127.0.0.1", port);
  auto res = client.Get("/api/scene");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
}

// Several requests on one connection, sent together, are answered in order (keep-alive with pipelining),
// and HEAD gets GET's headers without the body.
TEST(ViewerServer, KeepAliveAnswersPipelinedRequestsInOrder) {
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(lrf::test::tiny_field("rgb")), options);
  const int port = server.start();
  const std::string answer = raw_exchange(port,
                                          "GET /api/scene HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"
                                          "HEAD /viewer.js HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"
                                          "GET /nothing-here HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
                                          false);
  const size_t scene = answer.find("HTTP/1.1 200"), head = answer.find("HTTP/1.1 200", scene + 1),
               missing = answer.find("HTTP/1.1 404");
  ASSERT_NE(scene, std::string::npos) << answer.substr(0, 200);
  ASSERT_NE(head, std::string::npos) << answer.substr(0, 200);
  ASSERT_NE(missing, std::string::npos) << answer.substr(0, 200);
  EXPECT_LT(head, missing);
  // The HEAD answer declares the script's length and sends none of it.
  const std::string head_answer = answer.substr(head, missing - head);
  EXPECT_NE(head_answer.find("Content-Length: "), std::string::npos);
  EXPECT_EQ(head_answer.find("lrfViewer"), std::string::npos);
}

TEST(ViewerServer, LatentFieldFramesAreDecoded) {
  const std::string field = lrf::test::tiny_field("latent");
  v::ServeOptions options;
  options.port = 0;
  v::ViewerServer server(lrf::open_field_frames(field), options);
  const int port = server.start();
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(60, 0);
  auto scene_res = client.Get("/api/scene");
  ASSERT_TRUE(scene_res);
  const auto scene = nlohmann::json::parse(scene_res->body);
  EXPECT_EQ(scene["space"], "latent");
  EXPECT_EQ(scene["size_multiple"], 8);
  auto frame = client.Get(frame_query(scene["views"][0], "t", 1).c_str());
  ASSERT_TRUE(frame);
  ASSERT_EQ(frame->status, 200) << frame->body;
  EXPECT_NE(frame->get_header_value("X-Lrf-Decode-Ms"), "0.0");
  const std::vector<uchar> bytes(frame->body.begin(), frame->body.end());
  EXPECT_EQ(cv::imdecode(bytes, cv::IMREAD_COLOR).size(), cv::Size(64, 48));
  // 60 wide is not a multiple of 8: refused, not decoded at a wrong size.
  auto bad = client.Get(with_param(frame_query(scene["views"][0], "t", 2), "w", "60").c_str());
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(bad->body.find("multiple of 8"), std::string::npos);
}

TEST(ViewerServer, CliRefusesBadOptions) {
  const std::string field = lrf::test::tiny_field("rgb");
  auto r = lrf::test::run_lrf("serve '" + field + "' --port 70000");
  EXPECT_NE(r.exit_code, 0);
  r = lrf::test::run_lrf("serve '" + field + "' --host 203.0.113.7 --port 0");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot listen"), std::string::npos) << r.output;
  r = lrf::test::run_lrf("serve /nonexistent/run");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("/nonexistent/run"), std::string::npos) << r.output;
}
