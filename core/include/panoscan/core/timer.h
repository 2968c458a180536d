// Wall-clock timing of pipeline steps (the seconds_* fields of every result and report).
#pragma once

#include <chrono>

namespace panoscan {

using SteadyTime = std::chrono::steady_clock::time_point;

inline SteadyTime steady_now() { return std::chrono::steady_clock::now(); }

// Seconds elapsed since `start` on the monotonic clock.
inline double seconds_since(SteadyTime start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Seconds from `from` to `to`.
inline double seconds_between(SteadyTime from, SteadyTime to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace panoscan
