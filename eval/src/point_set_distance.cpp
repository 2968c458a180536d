// Nearest-point distances with a nanoflann kd-tree (exact search: eps = 0).

#include "panoscan/eval/point_set_distance.h"

#include "panoscan/core/kdtree.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace panoscan::eval {

struct PointSetDistance::Impl {
  explicit Impl(std::vector<Eigen::Vector3d> points) : tree(std::move(points)) {}
  PointKdTree tree;
};

PointSetDistance::PointSetDistance(std::vector<Eigen::Vector3d> points)
    : impl_(std::make_unique<Impl>(std::move(points))) {}

PointSetDistance::~PointSetDistance() = default;

std::size_t PointSetDistance::size() const { return impl_->tree.size(); }

double PointSetDistance::nearest(const Eigen::Vector3d& query, long* index) const {
  std::uint32_t found = 0;
  double squared_distance = 0.0;
  if (impl_->tree.knn(query, 1, &found, &squared_distance) == 0) {
    if (index) *index = -1;
    return std::numeric_limits<double>::infinity();
  }
  if (index) *index = static_cast<long>(found);
  // Recompute from the point itself rather than trust the accumulated squared distance.
  return (impl_->tree.points()[found] - query).norm();
}

std::vector<double> PointSetDistance::nearest_distances(const std::vector<Eigen::Vector3d>& queries) const {
  std::vector<double> result(queries.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) result[i] = nearest(queries[i]);
                    });
  return result;
}

}  // namespace panoscan::eval
