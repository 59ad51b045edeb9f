#pragma once
// A small HTTP/1.1 server for GET and HEAD requests only, with every request's size bounded before it
// is read: the request line and headers (the "head") at most max_head bytes, the target at most
// max_target, and no body at all. One thread waits on every connection at once and reads heads as their
// bytes arrive, so a connection that sends half a request holds a buffer of at most max_head bytes and no
// thread; only complete requests reach the handler threads. A head must arrive within head_timeout_ms of
// its first byte, an idle kept-alive connection is closed after idle_timeout_ms, and past
// max_connections the connection idle or waiting longest is closed to make room.
//
// Refused before the handler sees them, each with a JSON body {"error": ...} and the connection closed:
// a method other than GET or HEAD (405), a declared body (413), a target longer than max_target (414), a
// head longer than max_head (431), anything that is not an HTTP/1.x request (400).
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace lrf::viewer {

struct HttpRequest {
  std::string method;  // "GET" or "HEAD"
  std::string path;    // percent-decoded, without the query
  std::multimap<std::string, std::string> params;            // the query's, percent-decoded
  std::vector<std::pair<std::string, std::string>> headers;  // names in lower case, in arrival order

  // The first value of header `name` (lower case), "" when absent; and how many it has.
  std::string header(const std::string& name) const;
  size_t header_count(const std::string& name) const;
};

struct HttpResponse {
  int status = 200;
  std::string content_type;
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;

  void set_header(const std::string& name, const std::string& value) { headers.emplace_back(name, value); }
  void set_content(std::string content, std::string type) {
    body = std::move(content);
    content_type = std::move(type);
  }
};

struct HttpLimits {
  size_t max_head = 16 * 1024;
  size_t max_target = 8 * 1024;
  int head_timeout_ms = 2000;
  int idle_timeout_ms = 5000;
  int write_timeout_s = 10;
  size_t max_connections = 512;
  int threads = 8;  // handler threads
};

// The body the server sends with a status it decides itself (and that a handler may use alike).
std::string http_error_body(const std::string& message);

class HttpServer {
 public:
  using Handler = std::function<void(const HttpRequest&, HttpResponse&)>;
  HttpServer(Handler handler, const HttpLimits& limits);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds host:port (0: any free port) and listens; returns the port, or -1 when the address cannot be
  // bound. Connections wait in the backlog until start().
  int bind(const std::string& host, int port);
  // Serves on background threads until stop() (also called by the destructor).
  void start();
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lrf::viewer
