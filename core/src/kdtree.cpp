#include "panoscan/core/kdtree.h"

#include <nanoflann.hpp>

namespace panoscan {

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

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor,
                                                   3, std::uint32_t>;

}  // namespace

struct PointKdTree::Impl {
  std::vector<Eigen::Vector3d> points;
  PointsAdaptor adaptor;
  std::unique_ptr<KdTree> tree;
};

PointKdTree::PointKdTree(std::vector<Eigen::Vector3d> points) : impl_(std::make_unique<Impl>()) {
  impl_->points = std::move(points);
  impl_->adaptor.points = &impl_->points;
  if (!impl_->points.empty())
    impl_->tree = std::make_unique<KdTree>(3, impl_->adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

PointKdTree::~PointKdTree() = default;

std::size_t PointKdTree::size() const { return impl_->points.size(); }
const std::vector<Eigen::Vector3d>& PointKdTree::points() const { return impl_->points; }

std::size_t PointKdTree::knn(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* indices,
                             double* squared_distances) const {
  if (!impl_->tree || k == 0) return 0;
  const double coords[3] = {query.x(), query.y(), query.z()};
  return impl_->tree->knnSearch(coords, k, indices, squared_distances);
}

long PointKdTree::nearest_within(const Eigen::Vector3d& query, double max_distance, double* squared_distance) const {
  if (!impl_->tree) return -1;
  // A one-point result set whose worst distance starts at the radius: the search prunes every
  // subtree farther than max_distance instead of first finding some nearest point far away.
  std::uint32_t index = 0;
  double d2 = 0.0;
  nanoflann::KNNResultSet<double, std::uint32_t> result(1);
  result.init(&index, &d2);
  d2 = max_distance * max_distance;
  const double coords[3] = {query.x(), query.y(), query.z()};
  impl_->tree->findNeighbors(result, coords, nanoflann::SearchParams());
  if (result.size() == 0) return -1;
  if (squared_distance) *squared_distance = d2;
  return static_cast<long>(index);
}

std::size_t PointKdTree::knn_within(const Eigen::Vector3d& query, std::size_t k, double max_distance,
                                    std::uint32_t* indices, double* squared_distances) const {
  if (!impl_->tree || k == 0) return 0;
  // As nearest_within: the worst distance starts at the radius, so farther subtrees are pruned.
  nanoflann::KNNResultSet<double, std::uint32_t> result(k);
  result.init(indices, squared_distances);
  squared_distances[k - 1] = max_distance * max_distance;
  const double coords[3] = {query.x(), query.y(), query.z()};
  impl_->tree->findNeighbors(result, coords, nanoflann::SearchParams());
  return result.size();
}

}  // namespace panoscan
