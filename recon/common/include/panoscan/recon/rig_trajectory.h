// The poses of every frame of one scan: what tracking (paper §4.1) estimates and panorama
// construction (§4.2) consumes. The same structure holds ground-truth poses for the "GT"
// baselines (eval builds it from a scan's groundtruth/).
//
// On disk (a folder): camK.txt TUM trajectories (world_from_camera, one line per frame of the
// scan's listing) and rig_estimate.json:
//   {"format": "panoscan-rig-trajectory", "version": 1,
//    "world_from_axis": {"translation": [...], "rotation_quaternion_xyzw": [...]},
//    "ref_from_cam": [pose, ...], "source": "...",
//    "written_by": {"version": ..., "source_revision": ...}}   (written, not required)
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/trajectory.h"

namespace panoscan {

struct RigTrajectory {
  // Per sensor, one pose per frame of the scan (same order and timestamps as ScanIndex::frames).
  std::vector<std::vector<StampedPose>> world_from_cam;
  // The paper's T_u: z is the rotation axis. Its origin lies on the axis at the point closest to
  // the reference camera's first centre (the translation along the axis is a free gauge of Eq. 2,
  // fixed this way); it is the panorama centre, and the panorama's model-view of frame ci is
  // T_u^-1 * T_ci (world_from_axis.inverse() * world_from_cam).
  Rigid3d world_from_axis = Rigid3d::Identity();
  // Extrinsics T_c: each camera in the reference camera's frame.
  std::vector<Rigid3d> ref_from_cam;
  std::string source;  // "tracked", "groundtruth", "calibrated", ...
};

// Checks that the trajectory matches the scan (sensor count, one pose per frame with equal
// timestamps, finite poses); throws Error naming `origin`.
void check_rig_trajectory(const RigTrajectory& trajectory, const ScanIndex& scan, const std::string& origin);

void write_rig_trajectory(const std::filesystem::path& dir, const RigTrajectory& trajectory, const RigInfo& rig);
RigTrajectory read_rig_trajectory(const std::filesystem::path& dir, const ScanIndex& scan);

// The axis frame with the gauge above: z along `axis_direction` (sign kept), origin the point
// of the line closest to `reference_centre`, x the reference camera's optical axis projected
// onto the plane orthogonal to the axis.
Rigid3d axis_frame(const Eigen::Vector3d& axis_point, const Eigen::Vector3d& axis_direction,
                   const Rigid3d& world_from_reference_cam);

}  // namespace panoscan
