// Which poses a stage uses for a scan, by name: the one rule behind every `--poses` option (the
// program's `recon panorama`, `export colmap|nerfstudio`) and the Python module's `poses=`.
#pragma once

#include <filesystem>
#include <string>

#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"
#include "panoscan/recon/tracking.h"

namespace panoscan {

// "ground-truth": the simulated scan's groundtruth/ (eval::groundtruth_rig_trajectory);
// "tracked": tracks the scan now and refuses an unreliable result (require_reliable_tracking);
// anything else: a `recon track` output folder (read_rig_trajectory). Throws Error naming the file.
RigTrajectory scan_poses(const std::string& poses, const std::filesystem::path& scan_dir, const ScanIndex& scan,
                         const TrackingOptions& tracking);

}  // namespace panoscan
