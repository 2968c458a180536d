#include "panoscan/core/log.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>

#include <unistd.h>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace panoscan {

namespace {

spdlog::logger& logger() {
  // Logs go to stderr so that stdout carries only results (tables, paths).
  static std::shared_ptr<spdlog::logger> instance = [] {
    auto l = spdlog::stderr_color_mt("panoscan");
    l->set_pattern("[%H:%M:%S.%e] %^%l%$ %v");
    l->set_level(spdlog::level::info);
    return l;
  }();
  return *instance;
}

// Progress bars are information: --quiet (warnings and errors only) hides them too.
std::atomic<bool> progress_enabled{true};

}  // namespace

void set_log_level(LogLevel level) {
  progress_enabled = level <= LogLevel::kInfo;
  static const spdlog::level::level_enum map[] = {spdlog::level::debug, spdlog::level::info, spdlog::level::warn,
                                                  spdlog::level::err, spdlog::level::off};
  logger().set_level(map[static_cast<int>(level)]);
}
void log_debug(const std::string& message) { logger().debug(message); }
void log_info(const std::string& message) { logger().info(message); }
void log_warn(const std::string& message) { logger().warn(message); }
void log_error(const std::string& message) { logger().error(message); }

struct Progress::State {
  std::string label;
  std::size_t total = 0;
  std::size_t done = 0;
  bool terminal = false;
  bool finished = false;
  int last_decile = -1;
  std::chrono::steady_clock::time_point start, last_draw;
  std::mutex mutex;

  void draw(bool force) {
    if (!progress_enabled) return;
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start).count();
    const double fraction = total ? double(done) / double(total) : 1.0;
    if (terminal) {
      if (!force && now - last_draw < std::chrono::milliseconds(100)) return;
      last_draw = now;
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(fraction * kWidth);
      std::string bar(filled, '#');
      bar.resize(kWidth, '-');
      const double eta = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
      std::fprintf(stderr, "\r%s [%s] %zu/%zu %.0fs eta %.0fs ", label.c_str(), bar.c_str(), done, total, elapsed, eta);
      std::fflush(stderr);
    } else {
      const int decile = static_cast<int>(fraction * 10);
      if (decile == last_decile && !force) return;
      last_decile = decile;
      std::fprintf(stderr, "%s: %zu/%zu (%.0f%%) %.1fs\n", label.c_str(), done, total, fraction * 100, elapsed);
    }
  }
};

Progress::Progress(std::string label, std::size_t total) : state_(new State) {
  state_->label = std::move(label);
  state_->total = total;
  state_->terminal = ::isatty(STDERR_FILENO) != 0;
  state_->start = state_->last_draw = std::chrono::steady_clock::now();
}

Progress::~Progress() {
  finish();
  delete state_;
}

void Progress::advance(std::size_t count) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->done += count;
  state_->draw(false);
}

void Progress::finish() {
  std::lock_guard<std::mutex> lock(state_->mutex);
  if (state_->finished) return;
  state_->finished = true;
  if (state_->terminal) {
    if (!progress_enabled) return;
    state_->draw(true);
    std::fprintf(stderr, "\n");
  } else if (state_->last_decile < 10) {
    state_->draw(true);
  }
}

}  // namespace panoscan
