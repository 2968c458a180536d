// Unsynchronized shutters (docs/ARCHITECTURE.md §6.4): each camera runs its own 30 Hz clock with a random start
// offset in [0, 1/fps), a small rate error and per-frame jitter. Timestamps are rounded to whole
// microseconds (what the files store) and are unique across all cameras.
#pragma once

#include <cstdint>
#include <vector>

#include "panoscan/sim/options.h"

namespace panoscan {

struct FrameTime {
  int sensor = 0;
  int index = 0;         // frame number of this camera's clock (before `every` selection)
  double timestamp = 0;  // seconds, multiple of 1e-6
};

// All frames that fall within [start_time, start_time + duration], per sensor, in time order,
// after the `every` / `max_frames` selection (which keeps the original timestamps).
std::vector<std::vector<FrameTime>> make_frame_schedule(const ShutterOptions& shutter, const OutputOptions& output,
                                                        int num_sensors, double duration, std::uint64_t seed);

}  // namespace panoscan
