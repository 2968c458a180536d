// The TSDF baseline of Tables 1 and 3: all frames of one scanning position, with the same poses as
// the panorama, integrated into a sparse (hashed) TSDF volume — Open3D's ScalableTSDFVolume,
// BundleFusion's defaults of 5 mm voxels and 6 cm truncation — and a marching-cubes mesh extracted.
#pragma once

#include <cstddef>
#include <string>

#include "panoscan/core/mesh.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"

namespace panoscan {

struct TsdfOptions {
  double voxel_m = 0.005;      // tsdf.voxel_m
  double truncation_m = 0.06;  // tsdf.truncation_m
  double max_depth_m = 4.0;    // tsdf.max_depth_m: depths beyond are not integrated (BundleFusion: 4 m)
  int frame_stride = 1;        // tsdf.frame_stride: every n-th frame of each camera
  void check(const std::string& origin = "<tsdf options>") const;
};

struct TsdfResult {
  TriangleMesh mesh;             // marching cubes, world frame
  PointCloud vertices;           // the mesh's vertices with colour (what Table 3 evaluates)
  std::size_t volume_units = 0;  // allocated 16^3 blocks
  std::size_t memory_bytes = 0;  // volume_units * 16^3 * voxel size (estimate of the volume's memory)
  double integrate_seconds = 0.0;
  double extract_seconds = 0.0;
};

// Integrates the frames in the scan's order (serially: the volume is not thread-safe; Open3D's
// own loops use OpenMP inside). Throws Error if the trajectory does not match the scan.
TsdfResult build_tsdf_baseline(const ScanIndex& scan, const RigTrajectory& trajectory, const TsdfOptions& options);

}  // namespace panoscan
