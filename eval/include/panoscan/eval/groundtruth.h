// Ground truth of a simulated scan in the form the reconstruction consumes, for the "GT"
// baselines and the tests: poses of every frame, the true axis (T_u with the gauge of
// rig_trajectory.h) and the true extrinsics. Only eval and tests read ground truth.
#pragma once

#include <filesystem>

#include "panoscan/recon/rig_trajectory.h"

namespace panoscan::eval {

// Reads <scan>/groundtruth/camK.txt and rig_truth.json; throws Error naming the file and field.
RigTrajectory groundtruth_rig_trajectory(const std::filesystem::path& scan_dir);

}  // namespace panoscan::eval
