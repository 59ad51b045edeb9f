#pragma once
// Headless Chromium driven through the DevTools protocol over a pipe (--remote-debugging-pipe: JSON
// messages separated by NUL bytes, the browser reading fd 3 and writing fd 4), so the browser test
// needs neither node nor a WebSocket client.
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "child_process.h"

namespace lrf::test {

// The Chromium of Debian's chromium package, or "" when it is not installed.
inline std::string find_chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/lib/chromium/chromium", "/usr/bin/chromium-browser"})
    if (::access(p, X_OK) == 0) return p;
  return "";
}

class Chromium {
 public:
  // Starts the browser with no page of ours yet (open_page opens them).
  Chromium(const std::string& exe, const std::string& profile_dir) {
    int to_browser[2], from_browser[2];
    if (::pipe(to_browser) != 0 || ::pipe(from_browser) != 0) throw std::runtime_error("pipe failed");
    std::filesystem::create_directories(profile_dir);
    // Flags that run in a container without a GPU, a sandbox or a network beyond loopback.
    process_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                                 "--disable-extensions", "--mute-audio", "--window-size=1000,700",
                                 "--user-data-dir=" + profile_dir, "--remote-debugging-pipe", "about:blank"},
        false, profile_dir + "/chromium.log",
        std::vector<std::pair<int, int>>{{to_browser[0], 3}, {from_browser[1], 4}});
    ::close(to_browser[0]);
    ::close(from_browser[1]);
    write_ = to_browser[1];
    read_ = from_browser[0];
  }
  ~Chromium() {
    try {
      call("Browser.close", {}, "", 5);
    } catch (...) {
    }
    process_->wait(5);
    ::close(write_);
    ::close(read_);
  }

  // Sends a command (to a page when `session` is given) and returns its result; throws on an error reply
  // or when no reply comes within `seconds`.
  nlohmann::json call(const std::string& method, const nlohmann::json& params = {}, const std::string& session = "",
                      double seconds = 30) {
    const int id = next_id_++;
    nlohmann::json message = {{"id", id}, {"method", method}, {"params", params.is_null() ? nlohmann::json::object() : params}};
    if (!session.empty()) message["sessionId"] = session;
    const std::string bytes = message.dump() + std::string(1, '\0');
    if (::write(write_, bytes.data(), bytes.size()) != static_cast<ssize_t>(bytes.size()))
      throw std::runtime_error("cannot write to the browser");
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
    while (true) {
      const nlohmann::json reply = next_message(deadline);
      if (!reply.contains("id") || reply["id"] != id) continue;  // events and other replies
      if (reply.contains("error")) throw std::runtime_error(method + ": " + reply["error"].dump());
      return reply["result"];
    }
  }

  // Opens `url` in a new window (so that pages opened side by side are all visible, not background tabs
  // whose timers the browser throttles) and returns the session id that drives it.
  std::string open_page(const std::string& url) {
    const std::string id = call("Target.createTarget", {{"url", url}, {"newWindow", true}})["targetId"];
    return call("Target.attachToTarget", {{"targetId", id}, {"flatten", true}})["sessionId"];
  }

  // Evaluates a JavaScript expression in the page (awaiting a promise) and returns its value.
  nlohmann::json eval(const std::string& session, const std::string& expression, double seconds = 30) {
    auto r = call("Runtime.evaluate", {{"expression", expression}, {"awaitPromise", true}, {"returnByValue", true}}, session,
                  seconds);
    if (r.contains("exceptionDetails")) throw std::runtime_error("page exception: " + r["exceptionDetails"].dump());
    return r["result"].contains("value") ? r["result"]["value"] : nlohmann::json();
  }

  // Polls `condition` (a JavaScript expression) in the page until it is true; false after `seconds`.
  bool wait_for(const std::string& session, const std::string& condition, double seconds) {
    const std::string js = "new Promise((resolve) => { const t0 = performance.now(); const check = () => { let ok = false; "
                           "try { ok = Boolean(" + condition + "); } catch (e) {} if (ok) resolve(true); else if "
                           "(performance.now() - t0 > " + std::to_string(static_cast<int>(seconds * 1000)) +
                           ") resolve(false); else setTimeout(check, 20); }; check(); })";
    // A page still loading replaces its JavaScript context: evaluate again in the new one.
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
    while (true) {
      try {
        return eval(session, js, seconds + 10).get<bool>();
      } catch (const std::runtime_error& e) {
        if (std::string(e.what()).find("context") == std::string::npos || std::chrono::steady_clock::now() > deadline) throw;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    }
  }

 private:
  nlohmann::json next_message(std::chrono::steady_clock::time_point deadline) {
    while (true) {
      const size_t end = buffer_.find('\0');
      if (end != std::string::npos) {
        auto message = nlohmann::json::parse(buffer_.substr(0, end));
        buffer_.erase(0, end + 1);
        return message;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) throw std::runtime_error("the browser did not answer in time");
      pollfd p{read_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char buf[65536];
      const ssize_t n = ::read(read_, buf, sizeof buf);
      if (n <= 0) throw std::runtime_error("the browser closed its pipe");
      buffer_.append(buf, static_cast<size_t>(n));
    }
  }

  std::unique_ptr<ChildProcess> process_;
  int write_ = -1, read_ = -1;
  int next_id_ = 1;
  std::string buffer_;
};

}  // namespace lrf::test
