// Logging and progress, kept behind this small header so that spdlog stays out of every file.
#pragma once

#include <cstddef>
#include <string>

namespace panoscan {

enum class LogLevel { kDebug, kInfo, kWarn, kError, kOff };

void set_log_level(LogLevel level);
void log_debug(const std::string& message);
void log_info(const std::string& message);
void log_warn(const std::string& message);
void log_error(const std::string& message);

// A progress bar on stderr for long work. Thread-safe advance(); redraws at most ~10 times per
// second. Silent when stderr is not a terminal except for a line every 10%.
class Progress {
 public:
  Progress(std::string label, std::size_t total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  void advance(std::size_t count = 1);
  void finish();

 private:
  struct State;
  State* state_;
};

}  // namespace panoscan
