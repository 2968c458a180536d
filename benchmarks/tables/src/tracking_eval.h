// The tracking metrics shared by Table 2 and Fig. 8 (driver-internal).
//
// "Stitched ground-truth depth": the scans carry no noiseless depth maps, so each sampled pixel of
// the noisy depth is back-projected with its true pose and snapped to the closest point of the mesh
// (points farther than 5 cm, i.e. depth edges and outliers, are dropped); that point, in the true
// camera frame, is then placed with the estimated pose and its distance to the mesh measured.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"
#include "panoscan/eval/mesh_distance.h"

namespace panoscan::tables::tracking_eval {

// Mesh points seen by the frames of `sensors`, in the true camera frame: [sensor][frame] -> points.
// Pixels sampled every stride_at_320_px pixels at 320 columns (scaled with the image width).
std::vector<std::vector<std::vector<Eigen::Vector3d>>> mesh_points_in_camera(const ScanIndex& scan,
                                                                             const RigTrajectory& truth,
                                                                             const eval::MeshDistance& mesh,
                                                                             const std::vector<int>& sensors,
                                                                             double stride_at_320_px);

// truth_from_estimate over the frames of `sensors`: rotation = the chordal mean of R_true R_est^T,
// translation = the difference of the centroids (the ATE's position-only alignment is
// ill-conditioned in tilt: the camera centres lie on a circle of about 10 cm).
Rigid3d pose_alignment(const RigTrajectory& truth, const RigTrajectory& estimate, const std::vector<int>& sensors);

// RMSE (m) of the stitched points of `sensors` placed by truth_from_estimate * estimate; NaN if none.
double stitched_rmse_m(const std::vector<std::vector<std::vector<Eigen::Vector3d>>>& points_in_camera,
                       const RigTrajectory& estimate, const Rigid3d& truth_from_estimate,
                       const eval::MeshDistance& mesh, const std::vector<int>& sensors);

// ATE (m, TUM definition) of one camera.
double ate_m(const RigTrajectory& truth, const RigTrajectory& estimate, int sensor);

}  // namespace panoscan::tables::tracking_eval
