#pragma once
// lrf serve's HTTP server: the viewer page's own files, the scene (GET /api/scene) and frames
// (GET /api/frame, JPEG; see frame_request.h), nothing else. Frames are rendered one at a time in arrival
// order, stale ones dropped (render_queue.h). Requests are bounded before they are read (no bodies, an
// 8 KiB target, a 16 KiB head; http_server.h) and, bound to a loopback address, must name a loopback host
// (a web page elsewhere cannot reach the server through DNS rebinding).
#include <memory>
#include <string>

#include "lrf/frames/field_frames.h"

namespace lrf::viewer {

struct ServeOptions {
  std::string host = "127.0.0.1";
  int port = 8080;     // 0: any free port (see ViewerServer::port)
  int max_side = 2048;  // largest frame side a page may ask for
  int threads = 32;    // request handler threads (connections waiting for a request hold none)
  int jpeg_quality = 90;
};

class ViewerServer {
 public:
  ViewerServer(std::unique_ptr<FieldFrames> frames, const ServeOptions& options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  // Binds and starts serving on a background thread; returns the port. Throws lrf::Error when the
  // address cannot be bound.
  int start();
  int port() const;
  // Stops serving and joins the thread (also done by the destructor).
  void stop();

  struct Stats {
    long frames = 0, stale = 0, busy = 0, rejected = 0;  // rendered; dropped as stale; turned away; bad requests
  };
  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// True for 127.0.0.0/8, ::1 and "localhost".
bool is_loopback_host(const std::string& host);

}  // namespace lrf::viewer
