// Integration of registered panoramas into one scene cloud (paper §5.2).
//
// Pixels of two panoramas that are each other's nearest neighbour (within lambda_a, in the
// scene frame) are a mergeable pair; union-find over all panoramas groups them (the disjoint
// sets U_j); each group becomes one point, and pixels without partners stay as they are.
// Merging rules (Table 5 rows):
//   kAlignOnly  no merging: all points of all panoramas, placed by their poses
//   kAverage    the Euclidean mean of a group
//   kMap        the MAP estimate of Eq. 10. Its closed form (Eq. 11) weights each observation
//               with a matrix W_k: with `MapWeighting::kInformation` (default) W_k = (R_k O_k R_k^T)^-1,
//               the exact minimiser of Eq. 10's Gaussian terms; with `kPaperInverseSqrt`
//               W_k = (R_k O_k R_k^T)^-1/2 as Eq. 11 is printed.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"
#include "panoscan/core/point_cloud.h"

namespace panoscan {

// One registered panorama's points in its own frame.
struct PanoramaPoints {
  Rigid3d world_from_panorama = Rigid3d::Identity();  // T_k
  std::vector<Eigen::Vector3d> points;                // P^A_k
  // O^A_k of Eq. 9 (m^2, panorama frame): the surface covariance plus the measurement
  // covariance, as for registration. The surface part matters: merged partners are the same
  // surface point only to within the sampling, and without it MAP would pull the fused point off
  // the surface (it would intersect skew rays); with it the in-plane position is averaged while
  // the position across the surface is weighted by each pixel's measured precision.
  std::vector<Eigen::Matrix3d> covariances;
  std::vector<Rgb8> colours;  // optional (empty or one per point)
};

enum class MergeMethod { kAlignOnly, kAverage, kMap };
enum class MapWeighting { kInformation, kPaperInverseSqrt };

const char* to_string(MergeMethod method);
MergeMethod merge_method_from_string(const std::string& name);  // align, average, map

struct IntegrationOptions {
  MergeMethod method = MergeMethod::kMap;
  MapWeighting weighting = MapWeighting::kInformation;
  double max_correspondence_m = 0.15;  // lambda_a
  int threads = 0;

  void check() const;
};

struct IntegrationResult {
  PointCloud cloud;                         // scene frame; variances = trace(covariance) / 3 per point
  std::vector<std::uint32_t> observations;  // per output point: how many pixels it merges
  std::size_t input_points = 0;
  std::size_t mutual_pairs = 0;    // mergeable pairs found
  std::size_t groups = 0;          // disjoint sets with more than one member
  std::size_t grouped_points = 0;  // input points inside such sets
};

// Throws Error on inconsistent input (sizes, non-finite values, non-positive-definite covariances
// when they are needed).
IntegrationResult integrate_panoramas(const std::vector<PanoramaPoints>& panoramas, const IntegrationOptions& options);

}  // namespace panoscan
