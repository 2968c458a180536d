// The one 3D-3D RANSAC of PanoScan (paper §4.1: "We utilize RANSAC to sample and reach a consensus
// on confident 3D transformations"; §5.1 uses the same between panoramas): minimal samples of 3
// distinct, non-collinear pairs, the closed-form fit (fit_rigid_transform), inliers with
// |a_i - T b_i| < threshold_i, then two refits on the consensus set.
#pragma once

#include <cstdint>
#include <vector>

#include "panoscan/core/geometry.h"

namespace panoscan {

struct RigidRansacResult {
  Rigid3d a_from_b = Rigid3d::Identity();
  std::vector<int> inliers;  // on failure: the largest consensus set found (for reporting)
};

// Returns false when fewer than max(3, min_inliers) pairs agree. The draws come from the
// RandomStream keyed by (seed, stream_key), so a call is reproducible and independent of others.
bool rigid_ransac(const std::vector<Eigen::Vector3d>& points_a, const std::vector<Eigen::Vector3d>& points_b,
                  const std::vector<double>& thresholds, int iterations, int min_inliers, std::uint64_t seed,
                  std::int64_t stream_key, RigidRansacResult* result);

}  // namespace panoscan
