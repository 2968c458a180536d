// 3D-3D RANSAC (rigid_ransac.h).
#include "panoscan/core/rigid_ransac.h"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "panoscan/core/random.h"

namespace panoscan {

double ransac_iterations_needed(double confidence, double inlier_share) {
  if (!(confidence > 0.0) || !(confidence < 1.0)) return std::numeric_limits<double>::infinity();
  const double all_inliers = inlier_share * inlier_share * inlier_share;  // one sample of 3
  if (all_inliers >= 1.0) return 1.0;
  if (!(all_inliers > 0.0)) return std::numeric_limits<double>::infinity();
  return std::ceil(std::log(1.0 - confidence) / std::log1p(-all_inliers));
}

bool rigid_ransac(const std::vector<Eigen::Vector3d>& points_a, const std::vector<Eigen::Vector3d>& points_b,
                  const std::vector<double>& thresholds, const RansacBudget& budget, int min_inliers,
                  std::uint64_t seed, std::int64_t stream_key, RigidRansacResult* result) {
  const int n = int(points_a.size());
  if (result) result->iterations = 0;
  if (n < std::max(3, min_inliers)) return false;
  RandomStream random(seed, stream_key, 0, RandomPurpose::kGeneric, 7);
  auto count_inliers = [&](const Rigid3d& a_from_b, std::vector<int>* inliers) {
    inliers->clear();
    for (int i = 0; i < n; ++i)
      if ((points_a[i] - a_from_b * points_b[i]).norm() < thresholds[i]) inliers->push_back(i);
  };
  std::vector<int> best, current;
  std::vector<Eigen::Vector3d> sample_a(3), sample_b(3);
  double needed = std::numeric_limits<double>::infinity();  // from the best consensus so far
  int iteration = 0;
  for (; iteration < budget.max_iterations; ++iteration) {
    if (iteration >= budget.min_iterations && double(iteration) >= needed) break;
    int idx[3];
    idx[0] = random.uniform_int(0, n - 1);
    do idx[1] = random.uniform_int(0, n - 1);
    while (idx[1] == idx[0]);
    do idx[2] = random.uniform_int(0, n - 1);
    while (idx[2] == idx[0] || idx[2] == idx[1]);
    for (int k = 0; k < 3; ++k) {
      sample_a[k] = points_a[idx[k]];
      sample_b[k] = points_b[idx[k]];
    }
    // Degenerate (nearly collinear) samples give no rotation.
    if ((sample_a[1] - sample_a[0]).cross(sample_a[2] - sample_a[0]).norm() < 1e-4) continue;
    Rigid3d hypothesis;
    if (!fit_rigid_transform(sample_b, sample_a, hypothesis)) continue;
    count_inliers(hypothesis, &current);
    if (current.size() > best.size()) {
      best.swap(current);
      needed = ransac_iterations_needed(budget.confidence, double(best.size()) / double(n));
    }
  }
  if (result) result->iterations = iteration;
  if (int(best.size()) < std::max(3, min_inliers)) {
    if (result) result->inliers = best;
    return false;
  }
  // Refit on the inliers twice (the consensus set may grow).
  Rigid3d a_from_b = Rigid3d::Identity();
  for (int refit = 0; refit < 2; ++refit) {
    std::vector<Eigen::Vector3d> in_a, in_b;
    for (int i : best) {
      in_a.push_back(points_a[i]);
      in_b.push_back(points_b[i]);
    }
    if (!fit_rigid_transform(in_b, in_a, a_from_b)) break;
    count_inliers(a_from_b, &current);
    if (int(current.size()) < std::max(3, min_inliers)) break;
    best.swap(current);
  }
  if (int(best.size()) < std::max(3, min_inliers)) {
    if (result) result->inliers = best;
    return false;
  }
  result->a_from_b = a_from_b;
  result->inliers = best;
  return true;
}

}  // namespace panoscan
