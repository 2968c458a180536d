// Nearest-point distances with a nanoflann kd-tree (exact search: eps = 0).

#include "panoscan/eval/point_set_distance.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace panoscan::eval {

namespace {

// nanoflann's dataset interface over a vector of points.
struct PointsAdaptor {
  const std::vector<Eigen::Vector3d>* points = nullptr;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t index, std::size_t dim) const { return (*points)[index][dim]; }
  template <class BoundingBox>
  bool kdtree_get_bbox(BoundingBox&) const {
    return false;  // let nanoflann compute it
  }
};

using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3,
                                        std::uint32_t>;

}  // namespace

struct PointSetDistance::Impl {
  std::vector<Eigen::Vector3d> points;
  PointsAdaptor adaptor;
  std::unique_ptr<KdTree> tree;
};

PointSetDistance::PointSetDistance(std::vector<Eigen::Vector3d> points) : impl_(std::make_unique<Impl>()) {
  impl_->points = std::move(points);
  impl_->adaptor.points = &impl_->points;
  if (!impl_->points.empty())
    impl_->tree = std::make_unique<KdTree>(3, impl_->adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

PointSetDistance::~PointSetDistance() = default;

std::size_t PointSetDistance::size() const { return impl_->points.size(); }

double PointSetDistance::nearest(const Eigen::Vector3d& query, long* index) const {
  if (!impl_->tree) {
    if (index) *index = -1;
    return std::numeric_limits<double>::infinity();
  }
  std::uint32_t found = 0;
  double squared_distance = 0.0;
  const double query_coords[3] = {query.x(), query.y(), query.z()};
  impl_->tree->knnSearch(query_coords, 1, &found, &squared_distance);
  if (index) *index = static_cast<long>(found);
  // Recompute from the point itself rather than trust the accumulated squared distance.
  return (impl_->points[found] - query).norm();
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
