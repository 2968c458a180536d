// What the stage-2 drivers (Table 4: registration, Table 5: integration) share: panoramas of the
// built-in scans from their ground-truth poses, cached on disk beside the scans, the settings
// derived from the size preset, and RMSE against the scene's mesh.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/eval/mesh_distance.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/stage2.h"
#include "panoscan/tables/tables.h"

namespace panoscan::tables::stage2 {

// The TSA panorama (the paper's method) of a built-in scan ("SO-1") from its ground-truth poses at
// the preset's H, so that stage 2 is measured without stage 1's pose errors. Cached on disk under
// <cache>/panoramas/<scan key>_gt_tsa_H<H> (file-locked like the scans; keyed by everything that
// changes it). Its world_from_pano is in the scene frame.
Panorama ground_truth_panorama(const std::string& label, const TablesOptions& options);

// The same from tracked poses (the paper's graph: `recon track`'s defaults without the depth
// odometry, use_papers_tracking_graph): stage 1 as a user runs it. Its
// world_from_pano is re-expressed in the scene frame by aligning the tracked reference camera's
// first frame with the truth (the tracker's gauge), so that it can be compared with the mesh; what
// remains is the panorama's own tracking error. Cached as <scan key>_tracked_tsa_H<H>.
Panorama tracked_panorama(const std::string& label, const TablesOptions& options);

// The ground-truth mesh of the scene a label belongs to ("SO-1" -> the office).
std::unique_ptr<eval::MeshDistance> scene_mesh(const std::string& label, const TablesOptions& options);

// Registration settings of the tables: the paper's (lambda_a = 0.15 m, 50 iterations, sigma_z <=
// 0.15 m) on every `registration_stride(H)`-th pixel row and column, so that registration sees
// the same number of points (a 512 x 256 grid) at every size and the outside references (PCL's
// GICP is single-threaded) stay affordable.
int registration_stride(int panorama_height);
PairRegistrationOptions registration_options(const TablesOptions& options);
// Integration and evaluation use every pixel.
PanoramaCloudOptions integration_cloud_options(const TablesOptions& options);

struct DistanceStats {
  double rmse_mm = 0, mean_mm = 0, median_mm = 0;
};
DistanceStats distance_stats(std::vector<double> distances_m);

}  // namespace panoscan::tables::stage2
