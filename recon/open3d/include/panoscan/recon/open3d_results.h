// What Open3D's GICP and TSDF volume give back (open3d_calls.h), as plain Eigen and std types: the
// module that runs Open3D (src/open3d_module.cpp) fills them without linking anything of PanoScan.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace panoscan::open3d_calls {

struct GicpResult {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double fitness = 0.0;      // inlier fraction within the correspondence distance
  double inlier_rmse = 0.0;  // over those inliers
  std::size_t correspondences = 0;
};

struct TsdfMesh {
  std::vector<Eigen::Vector3d> vertices, colours;  // colours in [0, 1], empty without
  std::vector<Eigen::Vector3i> triangles;
  std::size_t volume_units = 0;  // allocated blocks
  int unit_resolution = 0;       // voxels per block edge
};

}  // namespace panoscan::open3d_calls
