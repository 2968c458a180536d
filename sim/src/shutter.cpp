#include "panoscan/sim/shutter.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "panoscan/core/random.h"

namespace panoscan {

std::vector<std::vector<FrameTime>> make_frame_schedule(const ShutterOptions& shutter, const OutputOptions& output,
                                                        int num_sensors, double duration, std::uint64_t seed) {
  std::vector<std::vector<FrameTime>> schedule(num_sensors);
  std::set<long long> used_microseconds;  // uniqueness across cameras
  const double nominal_period = 1.0 / shutter.fps;
  for (int sensor = 0; sensor < num_sensors; ++sensor) {
    RandomStream rng(seed, sensor, 0, RandomPurpose::kShutter);
    const double random_offset = rng.uniform(0.0, nominal_period);
    const double random_drift = rng.uniform(-1.0, 1.0) * shutter.drift_ppm * 1e-6;
    const double offset = shutter.synchronized ? 0.5 * nominal_period : random_offset;
    const double drift = shutter.synchronized ? 0.0 : random_drift;
    const double period = nominal_period / (1.0 + drift);
    const double jitter_std = shutter.synchronized ? 0.0 : shutter.jitter_ms * 1e-3;
    // Bounded jitter keeps each camera's frames in order and about one period apart.
    const double jitter_limit = std::min(3.0 * jitter_std, 0.2 * period);
    long long previous = -1;
    for (int k = 0;; ++k) {
      const double nominal = offset + k * period;
      if (nominal > duration) break;
      const double jitter = std::clamp(rng.normal() * jitter_std, -jitter_limit, jitter_limit);
      const double t = std::clamp(nominal + jitter, 0.0, duration);
      long long micros = std::llround((shutter.start_time_s + t) * 1e6);
      if (micros <= previous) micros = previous + 1;
      while (used_microseconds.count(micros)) ++micros;  // never share a timestamp
      used_microseconds.insert(micros);
      previous = micros;
      if (k % output.every != 0) continue;
      if (output.max_frames > 0 && int(schedule[sensor].size()) >= output.max_frames) continue;
      schedule[sensor].push_back({sensor, k, micros * 1e-6});
    }
  }
  return schedule;
}

}  // namespace panoscan
