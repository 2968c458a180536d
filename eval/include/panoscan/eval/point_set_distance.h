// Distance from query points to the nearest point of a point set (a kd-tree, nanoflann).
// Used for completeness (ground-truth samples -> nearest reconstructed point) and as the
// "sampled mesh" reference in the benchmark. Build once; queries are thread-safe.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

namespace panoscan::eval {

class PointSetDistance {
 public:
  // Copies the points. An empty set is allowed: every distance is then +infinity.
  explicit PointSetDistance(std::vector<Eigen::Vector3d> points);
  ~PointSetDistance();
  PointSetDistance(const PointSetDistance&) = delete;
  PointSetDistance& operator=(const PointSetDistance&) = delete;

  // Exact Euclidean distance to the nearest point, and its index (or -1 for an empty set).
  double nearest(const Eigen::Vector3d& query, long* index = nullptr) const;
  // Distances of all queries, in parallel (oneTBB), deterministic.
  std::vector<double> nearest_distances(const std::vector<Eigen::Vector3d>& queries) const;

  std::size_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace panoscan::eval
