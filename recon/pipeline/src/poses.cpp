#include "panoscan/recon/poses.h"

#include "panoscan/eval/groundtruth.h"

namespace panoscan {

RigTrajectory scan_poses(const std::string& poses, const std::filesystem::path& scan_dir, const ScanIndex& scan,
                         const TrackingOptions& tracking) {
  if (poses == "ground-truth") return eval::groundtruth_rig_trajectory(scan_dir);
  if (poses == "tracked") {
    TrackingResult tracked = track_scan(scan, tracking);
    require_reliable_tracking(tracked, tracking, scan_dir.string());
    return std::move(tracked.trajectory);
  }
  return read_rig_trajectory(poses, scan);
}

}  // namespace panoscan
