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
  int iterations = 0;        // minimal samples drawn
};

// How many minimal samples to draw: at most max_iterations; with confidence in (0, 1), stop as soon
// as, given the largest consensus set so far (inlier share w), an all-inlier sample would have been
// drawn with that probability: after k >= ransac_iterations_needed(confidence, w) draws (Fischler &
// Bolles' stopping rule, as OpenCV's and PCL's RANSAC apply it), but never before min_iterations.
// confidence >= 1 draws all max_iterations.
struct RansacBudget {
  int max_iterations = 200;
  double confidence = 1.0;
  int min_iterations = 0;
};

// Draws k needed for P(at least one all-inlier sample of 3) >= confidence at inlier share w:
// k = log(1 - confidence) / log(1 - w^3), rounded up (a huge number when w^3 is tiny).
double ransac_iterations_needed(double confidence, double inlier_share);

// Returns false when fewer than max(3, min_inliers) pairs agree. The draws come from the
// RandomStream keyed by (seed, stream_key), so a call is reproducible and independent of others.
// result->iterations says how many samples were drawn.
bool rigid_ransac(const std::vector<Eigen::Vector3d>& points_a, const std::vector<Eigen::Vector3d>& points_b,
                  const std::vector<double>& thresholds, const RansacBudget& budget, int min_inliers,
                  std::uint64_t seed, std::int64_t stream_key, RigidRansacResult* result);

}  // namespace panoscan
