#include "lrf/viewer/viewer_server.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <map>
#include <mutex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/viewer/frame_request.h"
#include "lrf/viewer/http_server.h"
#include "lrf/viewer/render_queue.h"
#include "lrf/viewer/scene_json.h"
#include "lrf/viewer/viewer_assets.h"

namespace lrf::viewer {
namespace {

void send_error(HttpResponse& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(http_error_body(message), "application/json");
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
  // The page's files by path, "/" for index.html.
  std::map<std::string, std::pair<std::string, std::string>> assets;  // path -> (body, content type)
  std::unique_ptr<HttpServer> server;
  int port = 0;
  std::atomic<long> frames_rendered{0}, busy{0}, rejected{0};

  void frame(const HttpRequest& req, HttpResponse& res);
  void handle(const HttpRequest& req, HttpResponse& res);
};

void ViewerServer::Impl::frame(const HttpRequest& req, HttpResponse& res) {
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

void ViewerServer::Impl::handle(const HttpRequest& req, HttpResponse& res) {
  // One Host, as HTTP/1.1 requires: with two, the check below and a proxy in front could each read another.
  if (req.header_count("host") > 1) return send_error(res, 400, "a request names one Host");
  if (is_loopback_host(options.host) && !is_loopback_host(host_name(req.header("host"))))
    return send_error(res, 403, "this server answers only requests addressed to the loopback host");
  // Paths are matched whole against the few the viewer serves: nothing is looked up on disk.
  if (const auto asset = assets.find(req.path); asset != assets.end()) {
    res.set_header("Cache-Control", "no-cache");
    res.set_header("X-Content-Type-Options", "nosniff");
    return res.set_content(asset->second.first, asset->second.second);
  }
  if (req.path == "/api/scene") {
    res.set_header("Cache-Control", "no-store");
    return res.set_content(scene, "application/json");
  }
  if (req.path == "/api/frame") {
    try {
      return frame(req, res);
    } catch (const std::exception& e) {
      ++rejected;
      log_warn(std::string("viewer: a request failed: ") + e.what());
      return send_error(res, 500, e.what());
    }
  }
  send_error(res, 404, "not found: the viewer serves only its page and /api/*");
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
  for (const auto& asset : viewer_assets()) {
    const std::string body(reinterpret_cast<const char*>(asset.data), asset.size);
    const std::string type = asset_content_type(asset.name);
    impl_->assets["/" + std::string(asset.name)] = {body, type};
    if (std::string(asset.name) == "index.html") impl_->assets["/"] = {body, type};
  }
  // Request heads are read by one thread that waits on every connection, so connections that send half
  // a request (or nothing) hold no handler thread and at most 16 KiB each (http_server.h).
  HttpLimits limits;
  limits.threads = options.threads;
  impl_->server = std::make_unique<HttpServer>([this](const HttpRequest& req, HttpResponse& res) { impl_->handle(req, res); },
                                               limits);
}

ViewerServer::~ViewerServer() { stop(); }

int ViewerServer::start() {
  // A browser that closes a tab mid-frame closes its socket; writing to it must be an error, not a
  // SIGPIPE that ends the process.
  std::signal(SIGPIPE, SIG_IGN);
  const int port = impl_->server->bind(impl_->options.host, impl_->options.port);
  if (port <= 0)
    fail("cannot listen on " + impl_->options.host + ":" + std::to_string(impl_->options.port) +
         " (address in use, or not an address of this machine)");
  impl_->port = port;
  impl_->server->start();
  return port;
}

int ViewerServer::port() const { return impl_->port; }

void ViewerServer::stop() {
  if (impl_ && impl_->server) impl_->server->stop();
}

ViewerServer::Stats ViewerServer::stats() const {
  return {impl_->frames_rendered.load(), static_cast<long>(impl_->queue.stale_count()), impl_->busy.load(),
          impl_->rejected.load()};
}

}  // namespace lrf::viewer
