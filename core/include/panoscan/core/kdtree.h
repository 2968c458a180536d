// A kd-tree over 3D points (nanoflann behind a pimpl): exact k-nearest and radius queries,
// thread-safe for concurrent queries once built.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace panoscan {

class PointKdTree {
 public:
  // Copies the points. An empty set is allowed (every query then finds nothing).
  explicit PointKdTree(std::vector<Eigen::Vector3d> points);
  ~PointKdTree();
  PointKdTree(const PointKdTree&) = delete;
  PointKdTree& operator=(const PointKdTree&) = delete;

  std::size_t size() const;
  const std::vector<Eigen::Vector3d>& points() const;

  // Up to k nearest points, closest first; returns how many were found.
  std::size_t knn(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* indices, double* squared_distances) const;
  // Nearest point within `max_distance`; -1 if none.
  long nearest_within(const Eigen::Vector3d& query, double max_distance, double* squared_distance = nullptr) const;
  // Up to k nearest points closer than `max_distance`, closest first; returns how many. Every point
  // not returned is at least as far as the k-th returned one, or as max_distance when fewer came back.
  std::size_t knn_within(const Eigen::Vector3d& query, std::size_t k, double max_distance, std::uint32_t* indices,
                         double* squared_distances) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace panoscan
