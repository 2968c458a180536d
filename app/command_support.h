// What several command files share (app-internal; the public argument structs are in commands.h).
#pragma once

#include <string>
#include <vector>

#include "panoscan/core/config.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"
#include "panoscan/recon/tracking.h"

namespace panoscan::app {

// A config file (optional) plus "key=value" overrides.
Config load_config(const std::string& file, const std::vector<std::string>& overrides);

// The poses a command should use for one scan: "ground-truth" (groundtruth/), "tracked" (tracks
// now and refuses an unreliable result) or a `recon track` output folder.
RigTrajectory scan_trajectory(const std::string& poses, const std::string& scan_dir, const ScanIndex& scan,
                              const TrackingOptions& tracking);

}  // namespace panoscan::app
