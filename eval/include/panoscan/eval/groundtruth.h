// Ground truth of a simulated scan in the form the reconstruction consumes, for the "GT"
// baselines and the tests: poses of every frame, the true axis (T_u with the gauge of
// rig_trajectory.h) and the true extrinsics. Only eval and tests read ground truth.
#pragma once

#include <filesystem>

#include "panoscan/recon/rig_trajectory.h"

namespace panoscan::eval {

// Reads <scan>/groundtruth/camK.txt and rig_truth.json; throws Error naming the file and field.
RigTrajectory groundtruth_rig_trajectory(const std::filesystem::path& scan_dir);

// The scene frame of a simulated scan from the frame of a reconstruction of it (tracked poses
// have their own world: the reference camera's first frame): the rigid transform that puts the
// first reconstructed pose of a camera onto that camera's first true pose. Throws Error when
// either list is empty.
Rigid3d scene_from_reconstruction(const std::vector<StampedPose>& true_poses,
                                  const std::vector<StampedPose>& reconstructed_poses);

}  // namespace panoscan::eval
