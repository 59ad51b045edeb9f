#include "lrf/viewer/http_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <string_view>
#include <thread>
#include <unordered_map>

namespace lrf::viewer {
namespace {

using Clock = std::chrono::steady_clock;

const char* reason_phrase(int status) {
  switch (status) {
    case 200: return "OK";
    case 204: return "No Content";
    case 400: return "Bad Request";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 413: return "Content Too Large";
    case 414: return "URI Too Long";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    default: return "Status";
  }
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX sequences decoded (a malformed one is kept as written); '+' is a space in a query only.
std::string percent_decode(std::string_view s, bool plus_is_space) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && hex_value(s[i + 1]) >= 0 && hex_value(s[i + 2]) >= 0) {
      out += static_cast<char>(hex_value(s[i + 1]) * 16 + hex_value(s[i + 2]));
      i += 2;
    } else if (plus_is_space && s[i] == '+') {
      out += ' ';
    } else {
      out += s[i];
    }
  }
  return out;
}

std::string trimmed(std::string_view s) {
  size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r')) --b;
  return std::string(s.substr(a, b - a));
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// What a connection's bytes so far make: not yet a whole head, a request, or a refusal.
struct ParsedHead {
  enum class Kind { incomplete, request, refused } kind = Kind::incomplete;
  HttpRequest request;
  size_t head_size = 0;
  bool keep_alive = false;
  int status = 0;
  std::string message;
};

ParsedHead refusal(int status, std::string message) {
  ParsedHead p;
  p.kind = ParsedHead::Kind::refused;
  p.status = status;
  p.message = std::move(message);
  return p;
}

ParsedHead parse_head(const std::string& bytes, const HttpLimits& limits) {
  // The request line alone is refused as soon as it is too long, without waiting for the rest.
  const size_t line_end = bytes.find('\n');
  if (line_end == std::string::npos && bytes.size() > limits.max_target + 64)
    return refusal(414, "the request target is longer than " + std::to_string(limits.max_target) + " bytes");
  size_t end = bytes.find("\r\n\r\n"), terminator = 4;
  if (const size_t bare = bytes.find("\n\n"); bare != std::string::npos && (end == std::string::npos || bare < end)) {
    end = bare;
    terminator = 2;
  }
  if (end == std::string::npos) {
    if (bytes.size() >= limits.max_head)
      return refusal(431, "the request's head is larger than " + std::to_string(limits.max_head) + " bytes");
    return {};
  }
  if (end + terminator > limits.max_head)
    return refusal(431, "the request's head is larger than " + std::to_string(limits.max_head) + " bytes");

  std::vector<std::string_view> lines;
  const std::string_view head(bytes.data(), end);
  for (size_t start = 0; start <= head.size();) {
    size_t nl = head.find('\n', start);
    if (nl == std::string_view::npos) nl = head.size();
    std::string_view line = head.substr(start, nl - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    start = nl + 1;
  }
  const std::string_view first = lines.front();
  const size_t sp1 = first.find(' '), sp2 = first.rfind(' ');
  if (sp1 == std::string_view::npos || sp2 == sp1) return refusal(400, "not an HTTP request");
  const std::string method(first.substr(0, sp1)), version(first.substr(sp2 + 1));
  const std::string_view target = first.substr(sp1 + 1, sp2 - sp1 - 1);
  if (version != "HTTP/1.1" && version != "HTTP/1.0") return refusal(400, "not an HTTP/1.x request");
  if (method.empty() || !std::all_of(method.begin(), method.end(), [](char c) { return c >= 'A' && c <= 'Z'; }))
    return refusal(400, "not an HTTP request");
  if (method != "GET" && method != "HEAD") return refusal(405, "only GET requests are served");
  if (target.size() > limits.max_target)
    return refusal(414, "the request target is longer than " + std::to_string(limits.max_target) + " bytes");
  if (target.empty() || target.front() != '/') return refusal(400, "the request target must be a path");

  ParsedHead p;
  p.kind = ParsedHead::Kind::request;
  p.head_size = end + terminator;
  HttpRequest& r = p.request;
  r.method = method;
  const size_t q = target.find('?');
  r.path = percent_decode(target.substr(0, q), false);
  if (q != std::string_view::npos) {
    const std::string_view query = target.substr(q + 1);
    for (size_t start = 0; start <= query.size();) {
      size_t amp = query.find('&', start);
      if (amp == std::string_view::npos) amp = query.size();
      const std::string_view pair = query.substr(start, amp - start);
      if (!pair.empty()) {
        const size_t eq = pair.find('=');
        r.params.emplace(percent_decode(pair.substr(0, eq), true),
                         eq == std::string_view::npos ? std::string() : percent_decode(pair.substr(eq + 1), true));
      }
      start = amp + 1;
    }
  }
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    // Folded continuation lines are obsolete and a way to smuggle a header past a proxy: refused.
    if (line.empty() || line.front() == ' ' || line.front() == '\t') return refusal(400, "a malformed header line");
    const size_t colon = line.find(':');
    if (colon == 0 || colon == std::string_view::npos) return refusal(400, "a malformed header line");
    const std::string name = lower(std::string(line.substr(0, colon)));
    if (name.find_first_of(" \t") != std::string::npos) return refusal(400, "a malformed header line");
    r.headers.emplace_back(name, trimmed(line.substr(colon + 1)));
  }
  const std::string length = r.header("content-length");
  if (r.header_count("transfer-encoding") > 0 || (!length.empty() && length != "0"))
    return refusal(413, "requests carry no body");
  const std::string connection = lower(r.header("connection"));
  p.keep_alive = version == "HTTP/1.1" ? connection != "close" : connection == "keep-alive";
  return p;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string serialise(const HttpResponse& res, bool head_only, bool keep_alive) {
  std::string out = "HTTP/1.1 " + std::to_string(res.status) + " " + reason_phrase(res.status) + "\r\n";
  const bool has_body = res.status != 204 && res.status != 304;
  if (has_body) {
    if (!res.content_type.empty()) out += "Content-Type: " + res.content_type + "\r\n";
    out += "Content-Length: " + std::to_string(res.body.size()) + "\r\n";
  }
  for (const auto& [name, value] : res.headers) out += name + ": " + value + "\r\n";
  out += keep_alive ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n";
  if (has_body && !head_only) out += res.body;
  return out;
}

void set_blocking(int fd, bool blocking) {
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, blocking ? flags & ~O_NONBLOCK : flags | O_NONBLOCK);
}

bool send_all(int fd, const std::string& bytes) {
  for (size_t sent = 0; sent < bytes.size();) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

std::string HttpRequest::header(const std::string& name) const {
  for (const auto& [n, v] : headers)
    if (n == name) return v;
  return "";
}

size_t HttpRequest::header_count(const std::string& name) const {
  return static_cast<size_t>(std::count_if(headers.begin(), headers.end(), [&](const auto& h) { return h.first == name; }));
}

std::string http_error_body(const std::string& message) { return "{\"error\":" + json_string(message) + "}"; }

struct HttpServer::Impl {
  Handler handler;
  HttpLimits limits;
  int listen_fd = -1;
  int wake_read = -1, wake_write = -1;
  std::atomic<bool> stopping{false};
  std::thread loop_thread;
  std::vector<std::thread> workers;

  // Connections the loop waits on, by descriptor.
  struct Connection {
    std::string bytes;  // received, not yet a whole head (or pipelined behind the last one)
    Clock::time_point deadline;
  };
  std::unordered_map<int, Connection> connections;

  // Whole requests for the handler threads, and connections they hand back to the loop.
  struct Job {
    int fd;
    HttpRequest request;
    bool keep_alive;
    std::string rest;  // bytes after the head
  };
  std::mutex mutex;
  std::condition_variable job_ready;
  std::deque<Job> jobs;
  std::vector<std::pair<int, std::string>> returned;
  bool workers_stop = false;

  void wake() {
    const char c = 1;
    [[maybe_unused]] const ssize_t n = ::write(wake_write, &c, 1);
  }

  void close_connection(int fd) {
    ::close(fd);
    connections.erase(fd);
  }

  // A refusal the loop sends itself: small enough for the socket's buffer, so a non-blocking send.
  void refuse(int fd, int status, const std::string& message) {
    HttpResponse res;
    res.status = status;
    res.set_content(http_error_body(message), "application/json");
    const std::string bytes = serialise(res, false, false);
    [[maybe_unused]] const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    close_connection(fd);
  }

  // Acts on what a connection has received: waits for more, refuses it, or hands a request over.
  void take_bytes(int fd) {
    Connection& c = connections.at(fd);
    ParsedHead p = parse_head(c.bytes, limits);
    if (p.kind == ParsedHead::Kind::incomplete) return;
    if (p.kind == ParsedHead::Kind::refused) return refuse(fd, p.status, p.message);
    Job job{fd, std::move(p.request), p.keep_alive, c.bytes.substr(p.head_size)};
    connections.erase(fd);
    {
      std::lock_guard<std::mutex> lock(mutex);
      jobs.push_back(std::move(job));
    }
    job_ready.notify_one();
  }

  // Closes the connection nearest its deadline: the one idle longest, or the slowest to send its head.
  void close_oldest() {
    auto oldest = std::min_element(connections.begin(), connections.end(),
                                   [](const auto& a, const auto& b) { return a.second.deadline < b.second.deadline; });
    if (oldest != connections.end()) close_connection(oldest->first);
  }

  void accept_all() {
    bool made_room = false;
    for (;;) {
      const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        // Out of descriptors (a low `ulimit -n`): a waiting connection gives its up, once per round, so
        // that a page's request is not locked out by idle ones.
        if ((errno == EMFILE || errno == ENFILE) && !made_room && !connections.empty()) {
          close_oldest();
          made_room = true;
          continue;
        }
        return;
      }
      if (connections.size() >= limits.max_connections) close_oldest();
      connections[fd].deadline = Clock::now() + std::chrono::milliseconds(limits.idle_timeout_ms);
    }
  }

  void read_from(int fd) {
    Connection& c = connections.at(fd);
    char buf[8192];
    // Never more than one byte past the head limit: what a connection may hold is bounded.
    const size_t room = std::min(sizeof buf, limits.max_head + 1 - std::min(c.bytes.size(), limits.max_head));
    const ssize_t n = ::recv(fd, buf, room, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) return close_connection(fd);
    if (n < 0) return;
    if (c.bytes.empty()) c.deadline = Clock::now() + std::chrono::milliseconds(limits.head_timeout_ms);
    c.bytes.append(buf, static_cast<size_t>(n));
    take_bytes(fd);
  }

  void loop() {
    std::vector<pollfd> fds;
    std::vector<int> ready;
    while (!stopping) {
      std::vector<std::pair<int, std::string>> back;
      {
        std::lock_guard<std::mutex> lock(mutex);
        back.swap(returned);
      }
      for (auto& [fd, rest] : back) {
        Connection& c = connections[fd];
        c.bytes = std::move(rest);
        c.deadline = Clock::now() + std::chrono::milliseconds(c.bytes.empty() ? limits.idle_timeout_ms : limits.head_timeout_ms);
        if (!c.bytes.empty()) take_bytes(fd);
      }
      const Clock::time_point now = Clock::now();
      for (auto it = connections.begin(); it != connections.end();) {
        if (it->second.deadline <= now) {
          ::close(it->first);
          it = connections.erase(it);
        } else {
          ++it;
        }
      }
      int timeout_ms = 1000;
      for (const auto& [fd, c] : connections) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(c.deadline - now).count() + 1;
        timeout_ms = static_cast<int>(std::clamp<long long>(left, 0, timeout_ms));
      }
      fds.clear();
      fds.push_back({wake_read, POLLIN, 0});
      fds.push_back({listen_fd, POLLIN, 0});
      for (const auto& [fd, c] : connections) fds.push_back({fd, POLLIN, 0});
      if (::poll(fds.data(), fds.size(), timeout_ms) < 0 && errno != EINTR) break;
      if (fds[0].revents) {
        char drain[64];
        while (::read(wake_read, drain, sizeof drain) > 0) {
        }
      }
      if (fds[1].revents & POLLIN) accept_all();
      ready.clear();
      for (size_t i = 2; i < fds.size(); ++i)
        if (fds[i].revents) ready.push_back(fds[i].fd);
      for (const int fd : ready)
        if (connections.count(fd)) read_from(fd);
    }
  }

  void serve(Job& job) {
    HttpResponse res;
    try {
      handler(job.request, res);
    } catch (const std::exception& e) {
      res = HttpResponse{};
      res.status = 500;
      res.set_content(http_error_body(e.what()), "application/json");
    }
    set_blocking(job.fd, true);
    timeval tv{limits.write_timeout_s, 0};
    ::setsockopt(job.fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    const bool keep = job.keep_alive && res.status < 400;
    const bool sent = send_all(job.fd, serialise(res, job.request.method == "HEAD", keep));
    if (!sent || !keep || stopping) {
      ::close(job.fd);
      return;
    }
    set_blocking(job.fd, false);
    {
      std::lock_guard<std::mutex> lock(mutex);
      returned.emplace_back(job.fd, std::move(job.rest));
    }
    wake();
  }

  void work() {
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex);
        job_ready.wait(lock, [&] { return workers_stop || !jobs.empty(); });
        if (workers_stop) return;
        job = std::move(jobs.front());
        jobs.pop_front();
      }
      serve(job);
    }
  }
};

HttpServer::HttpServer(Handler handler, const HttpLimits& limits) : impl_(std::make_unique<Impl>()) {
  impl_->handler = std::move(handler);
  impl_->limits = limits;
}

HttpServer::~HttpServer() {
  stop();
  if (impl_->listen_fd >= 0) ::close(impl_->listen_fd);
}

int HttpServer::bind(const std::string& host, int port) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0) return -1;
  int fd = -1;
  for (addrinfo* a = found; a && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int yes = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) != 0 || ::listen(fd, 512) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  if (fd < 0) return -1;
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  impl_->listen_fd = fd;
  if (addr.ss_family == AF_INET6) return ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port);
  return ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
}

void HttpServer::start() {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_NONBLOCK | O_CLOEXEC) != 0) throw std::runtime_error("cannot make the server's wake pipe");
  impl_->wake_read = pipe_fds[0];
  impl_->wake_write = pipe_fds[1];
  for (int i = 0; i < std::max(1, impl_->limits.threads); ++i) impl_->workers.emplace_back([this] { impl_->work(); });
  impl_->loop_thread = std::thread([this] { impl_->loop(); });
}

void HttpServer::stop() {
  Impl& s = *impl_;
  if (!s.loop_thread.joinable()) return;
  s.stopping = true;
  s.wake();
  s.loop_thread.join();
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.workers_stop = true;
  }
  s.job_ready.notify_all();
  for (std::thread& t : s.workers) t.join();
  s.workers.clear();
  for (const auto& [fd, c] : s.connections) ::close(fd);
  s.connections.clear();
  for (const auto& job : s.jobs) ::close(job.fd);
  s.jobs.clear();
  for (const auto& [fd, rest] : s.returned) ::close(fd);
  s.returned.clear();
  ::close(s.wake_read);
  ::close(s.wake_write);
}

}  // namespace lrf::viewer
