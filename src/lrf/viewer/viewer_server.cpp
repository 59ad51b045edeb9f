#include "lrf/viewer/viewer_server.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <mutex>
#include <thread>

#include <httplib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/viewer/frame_request.h"
#include "lrf/viewer/render_queue.h"
#include "lrf/viewer/scene_json.h"
#include "lrf/viewer/viewer_assets.h"

namespace lrf::viewer {
namespace {

void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(nlohmann::json{{"error", message}}.dump(), "application/json");
}

// The Host header without its port: "127.0.0.1:8080" -> "127.0.0.1", "[::1]:8080" -> "::1".
std::string host_name(const std::string& header) {
  if (!header.empty() && header.front() == '[') {
    const size_t close = header.find(']');
    return close == std::string::npos ? header : header.substr(1, close - 1);
  }
  return header.substr(0, header.find(':'));
}

}  // namespace

bool is_loopback_host(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

struct ViewerServer::Impl {
  std::unique_ptr<FieldFrames> frames;
  ServeOptions options;
  ViewLimits limits;
  std::string scene;  // GET /api/scene's body, made once
  RenderQueue queue;
  std::mutex render_mutex;  // the queue grants one turn at a time; this guards the renderer regardless
  httplib::Server server;
  std::thread thread;
  int port = 0;
  std::atomic<long> frames_rendered{0}, busy{0}, rejected{0};

  void frame(const httplib::Request& req, httplib::Response& res);
  void routes();
};

void ViewerServer::Impl::frame(const httplib::Request& req, httplib::Response& res) {
  FrameRequest request;
  try {
    request = parse_frame_request(req.params, limits);
  } catch (const lrf::Error& e) {
    ++rejected;
    return send_error(res, 400, e.what());
  }
  const auto waited = std::chrono::steady_clock::now();
  auto turn = queue.acquire(request.client, request.seq);
  if (turn.outcome() == RenderQueue::Outcome::stale) {
    // 204 tells the page that a newer frame of its own is on the way; nothing to draw.
    res.status = 204;
    res.set_header("X-Lrf-Seq", std::to_string(request.seq));
    return;
  }
  if (turn.outcome() == RenderQueue::Outcome::busy) {
    ++busy;
    return send_error(res, 503, "busy: too many frames are waiting; retry");
  }
  const double queue_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - waited).count();
  FrameTiming timing;
  cv::Mat rgb;
  {
    std::lock_guard<std::mutex> lock(render_mutex);
    rgb = frames->render(request.camera, &timing);
  }
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uchar> jpeg;
  if (!cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality}))
    return send_error(res, 500, "cannot encode the frame as JPEG");
  ++frames_rendered;
  char ms[64];
  res.set_header("X-Lrf-Seq", std::to_string(request.seq));
  std::snprintf(ms, sizeof ms, "%.1f", timing.render_ms);
  res.set_header("X-Lrf-Render-Ms", ms);
  std::snprintf(ms, sizeof ms, "%.1f", timing.decode_ms);
  res.set_header("X-Lrf-Decode-Ms", ms);
  std::snprintf(ms, sizeof ms, "%.1f", queue_ms);
  res.set_header("X-Lrf-Queue-Ms", ms);
  res.set_header("Cache-Control", "no-store");
  res.set_content(std::string(jpeg.begin(), jpeg.end()), "image/jpeg");
}

void ViewerServer::Impl::routes() {
  const bool loopback = is_loopback_host(options.host);
  server.set_pre_routing_handler([loopback](const httplib::Request& req, httplib::Response& res) {
    if (req.method != "GET" && req.method != "HEAD") {
      send_error(res, 405, "only GET requests are served");
      return httplib::Server::HandlerResponse::Handled;
    }
    // cpp-httplib reads no body for a GET, so a declared one is refused by its headers too.
    const std::string length = req.get_header_value("Content-Length");
    if (!req.body.empty() || req.has_header("Transfer-Encoding") || (!length.empty() && length != "0")) {
      send_error(res, 413, "requests carry no body");
      return httplib::Server::HandlerResponse::Handled;
    }
    // One Host, as HTTP/1.1 requires: with two, the check below and a proxy in front could each read another.
    if (req.get_header_value_count("Host") > 1) {
      send_error(res, 400, "a request names one Host");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (loopback && !is_loopback_host(host_name(req.get_header_value("Host")))) {
      send_error(res, 403, "this server answers only requests addressed to the loopback host");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  for (const auto& asset : viewer_assets()) {
    const std::string name = asset.name;
    const std::string body(reinterpret_cast<const char*>(asset.data), asset.size);
    const std::string type = asset_content_type(name);
    auto serve = [body, type](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-cache");
      res.set_header("X-Content-Type-Options", "nosniff");
      res.set_content(body, type.c_str());
    };
    // Routes are regular expressions matched against the whole path: the name's dots are literal.
    std::string pattern = "/";
    for (char ch : name) pattern += ch == '.' ? std::string("\\.") : std::string(1, ch);
    server.Get(pattern, serve);
    if (name == "index.html") server.Get("/", serve);
  }
  server.Get("/api/scene", [this](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(scene, "application/json");
  });
  server.Get("/api/frame", [this](const httplib::Request& req, httplib::Response& res) { frame(req, res); });
  server.set_error_handler([](const httplib::Request&, httplib::Response& res) {
    // Unknown paths and cpp-httplib's own refusals (too long a URI or header, ...) get a short JSON body.
    if (res.body.empty())
      send_error(res, res.status, res.status == 404 ? "not found: the viewer serves only its page and /api/*"
                                                    : "request refused (status " + std::to_string(res.status) + ")");
  });
  server.set_exception_handler([this](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "internal error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    ++rejected;
    log_warn("viewer: a request failed: " + what);
    send_error(res, 500, what);
  });
}

ViewerServer::ViewerServer(std::unique_ptr<FieldFrames> frames, const ServeOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (options.port < 0 || options.port > 65535) fail_usage("--port must be in 0..65535");
  if (options.max_side < 8 || options.max_side > 8192) fail_usage("--max-side must be in 8..8192");
  if (options.threads < 2 || options.threads > 1024) fail("the server needs 2..1024 connection threads");
  impl_->frames = std::move(frames);
  impl_->options = options;
  impl_->limits = view_limits(*impl_->frames, options.max_side);
  impl_->scene = scene_json(*impl_->frames, impl_->limits).dump();
  const size_t threads = static_cast<size_t>(options.threads);
  impl_->server.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  // No request has a body; idle connections are closed soon so that they do not hold threads: each
  // connection holds one of the pool's threads while it waits, so 60 silent connections made a page's
  // request wait 6.5 s behind them at the former 5 s read and 2 s keep-alive timeouts. A page's GET arrives
  // whole within milliseconds of its connection, and the browser reconnects when a kept-alive one was
  // closed; 1 s is the shortest keep-alive timeout cpp-httplib has (it counts whole seconds).
  impl_->server.set_payload_max_length(1024);
  impl_->server.set_read_timeout(1, 0);
  impl_->server.set_write_timeout(10, 0);
  impl_->server.set_keep_alive_timeout(1);
  impl_->server.set_keep_alive_max_count(1000);
  impl_->routes();
}

ViewerServer::~ViewerServer() { stop(); }

int ViewerServer::start() {
  // A browser that closes a tab mid-frame closes its socket; writing to it must be an error cpp-httplib
  // handles, not a SIGPIPE that ends the process.
  std::signal(SIGPIPE, SIG_IGN);
  auto& s = impl_->server;
  const int port = impl_->options.port == 0 ? s.bind_to_any_port(impl_->options.host)
                                            : (s.bind_to_port(impl_->options.host, impl_->options.port) ? impl_->options.port : -1);
  if (port <= 0)
    fail("cannot listen on " + impl_->options.host + ":" + std::to_string(impl_->options.port) +
         " (address in use, or not an address of this machine)");
  impl_->port = port;
  // The socket listens from here on: connections made before the accept loop starts wait in its backlog.
  impl_->thread = std::thread([&s] { s.listen_after_bind(); });
  return port;
}

int ViewerServer::port() const { return impl_->port; }

void ViewerServer::stop() {
  if (!impl_) return;
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

ViewerServer::Stats ViewerServer::stats() const {
  return {impl_->frames_rendered.load(), static_cast<long>(impl_->queue.stale_count()), impl_->busy.load(),
          impl_->rejected.load()};
}

}  // namespace lrf::viewer
