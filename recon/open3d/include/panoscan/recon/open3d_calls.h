// Open3D's GICP, hashed TSDF volume and RGB-D odometry for the baselines and outside references,
// through a module loaded on first use (src/open3d_module.cpp says why). Every failure, a module
// that cannot be loaded included, is an Error naming `origin`.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/camera.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/open3d_results.h"

namespace panoscan::open3d_calls {

// Loads the module now; the first call below would otherwise. For timings that must not include it
// (~0.04 s and ~100 shared libraries, once per process).
void load();

// open3d::pipelines::registration::RegistrationGeneralizedICP with ICPConvergenceCriteria(1e-6,
// 1e-6, max_iterations).
GicpResult generalized_icp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                           double max_correspondence_m, const Eigen::Matrix4d& initial_target_from_source,
                           int max_iterations);

// open3d::pipelines::integration::ScalableTSDFVolume with RGB8 colour.
class TsdfVolume {
 public:
  TsdfVolume(double voxel_m, double truncation_m);
  ~TsdfVolume();
  TsdfVolume(const TsdfVolume&) = delete;
  TsdfVolume& operator=(const TsdfVolume&) = delete;
  // Depth beyond max_depth_m is not integrated.
  void integrate(const RgbdFrame& frame, double max_depth_m, const PinholeIntrinsics& k,
                 const Eigen::Matrix4d& cam_from_world);
  TsdfMesh extract_mesh() const;

 private:
  void* volume_;
};

// An Open3D RGB-D image of a frame (depth in metres up to max_depth_m; `intensity`: grey, as the
// odometry needs).
class RgbdImage {
 public:
  RgbdImage(const RgbdFrame& frame, double max_depth_m, bool intensity);
  ~RgbdImage();
  RgbdImage(RgbdImage&& other) noexcept;
  RgbdImage& operator=(RgbdImage&& other) noexcept;
  RgbdImage(const RgbdImage&) = delete;
  RgbdImage& operator=(const RgbdImage&) = delete;
  const void* handle() const { return image_; }

 private:
  void* image_;
};

struct OdometryStep {
  bool converged = false;
  Eigen::Matrix4d previous_from_current = Eigen::Matrix4d::Identity();  // Open3D's answer, also when not converged
};

// open3d::pipelines::odometry::ComputeRGBDOdometry (hybrid term) of `current` against `previous`,
// Open3D's warnings silenced.
OdometryStep rgbd_odometry(const RgbdImage& current, const RgbdImage& previous, const PinholeIntrinsics& k,
                           const Eigen::Matrix4d& initial, const std::vector<int>& iterations_per_level,
                           double max_depth_difference_m, double min_depth_m, double max_depth_m);

}  // namespace panoscan::open3d_calls
