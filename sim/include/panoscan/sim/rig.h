// The sensor rig: three cameras on one bracket, the bracket on the rotator.
//
// Frames: axis frame A (origin on the rotation axis at the floor, z along the axis, x the
// rig's heading at azimuth 0), bracket frame B (x forward, y left, z up), camera frames
// (OpenCV). The true installation axis_from_bracket is the paper's unknown T_u (as seen from
// the axis); bracket_from_cam are the true extrinsics.
#pragma once

#include <vector>

#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/sim/options.h"

namespace panoscan {

struct RigModel {
  PinholeIntrinsics intrinsics;
  int reference_sensor = 1;
  std::vector<double> pitches_rad;
  Rigid3d axis_from_bracket = Rigid3d::Identity();
  std::vector<Rigid3d> bracket_from_cam;         // true
  std::vector<Rigid3d> ref_from_cam_true;        // true extrinsics relative to the reference camera
  std::vector<Rigid3d> ref_from_cam_calibrated;  // with the configured calibration error

  std::size_t num_sensors() const { return bracket_from_cam.size(); }
  // Pairs (lower, upper) of sensors whose views overlap in a horizontal band: the bottom rows of
  // `upper` and the top rows of `lower` (adjacent pitches).
  std::vector<std::pair<int, int>> vertical_neighbours() const;
};

RigModel make_rig(const RigOptions& options, std::uint64_t seed);

}  // namespace panoscan
