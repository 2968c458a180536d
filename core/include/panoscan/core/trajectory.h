// TUM trajectory files: one line per pose, "timestamp tx ty tz qx qy qz qw", the pose being
// world_from_camera. Lines starting with '#' are comments.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "panoscan/core/geometry.h"

namespace panoscan {

struct StampedPose {
  double timestamp = 0.0;
  Rigid3d world_from_cam = Rigid3d::Identity();
};

// Validates: 8 finite numbers per line, unit-normalisable quaternion, strictly increasing
// timestamps. Throws Error naming the file and line.
std::vector<StampedPose> read_tum_trajectory(const std::filesystem::path& path);
// Atomic write; timestamps with 6 decimals, translations and quaternions with 9.
void write_tum_trajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses);

// The pose at each of `times` from a trajectory sorted by time (as read_tum_trajectory returns it):
// a pose stamped exactly at that time, else the interpolation between the two poses that bracket
// it (translation linear, rotation slerp) when both lie within max_dt seconds of it; no pose
// before the first pose, after the last or across a gap wider than that. Throws Error for
// unsorted poses or a max_dt that is not finite and >= 0.
std::vector<std::optional<Rigid3d>> interpolate_trajectory(const std::vector<StampedPose>& poses,
                                                           const std::vector<double>& times, double max_dt);

// "%.6f": the canonical text of a timestamp in listings, trajectories and file names.
std::string format_timestamp(double timestamp);

}  // namespace panoscan
