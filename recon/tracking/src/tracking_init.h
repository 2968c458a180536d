// Initialisation of the joint tracking (internal): first odometry of the reference camera and a
// first axis estimate.
#pragma once

#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/recon/frontend.h"

namespace panoscan::tracking_init {

// world_from_ref per frame of `sensor` (world = its first frame), chaining the verified
// frame-to-frame transforms (nearest earlier frame with a verified pair); a frame without one
// continues at the previous relative motion (constant velocity), and the frames before the first
// verified pair lie back in time along the first verified motion, at its rate. `verified` counts the
// chained frames.
std::vector<Rigid3d> chain_odometry(const FrontendResult& frontend, int sensor, int* verified);

struct AxisEstimate {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  bool from_rotation = false;  // false: too little rotation, the fallback (camera's -y through its centre)
};
// Direction: mean rotation vector of the poses relative to the first (sign of the first large one);
// point: least-squares fixed point, sum |(I - R_i) p - t_i|^2, closest to the first centre.
AxisEstimate fit_axis(const std::vector<Rigid3d>& world_from_cam, double min_rotation_rad = 0.1);

// The rotation angle of R about `axis` (swing-twist decomposition, the twist angle), in (-pi, pi].
double twist_angle(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& axis);

}  // namespace panoscan::tracking_init
