// Local surface of every point from its k nearest neighbours: the normal, the curvature and
// Generalized-ICP's plane-shaped covariance (Segal et al. 2009, §III-B). The neighbours come from a
// kd-tree, or, for a cloud sampled from a grid (RegistrationCloud::grid_cells), from the grid
// window around each point.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/recon/registration.h"

namespace panoscan {

namespace {

constexpr std::int32_t kEmptyCell = -1;

// Checks the grid fields of an organised cloud; throws naming the field.
void check_grid(const RegistrationCloud& cloud) {
  if (cloud.grid_cells.size() != cloud.points.size())
    throw make_error("", "registration cloud grid_cells",
                     std::to_string(cloud.grid_cells.size()) + " cells for " + std::to_string(cloud.points.size()) +
                         " points (one per point expected)");
  if (cloud.grid_width <= 0 || cloud.grid_height <= 0)
    throw make_error("", "registration cloud grid_width/grid_height", "must be positive for an organised cloud");
  const std::uint64_t cells = std::uint64_t(cloud.grid_width) * std::uint64_t(cloud.grid_height);
  if (cells > std::uint64_t(std::numeric_limits<std::int32_t>::max()))
    throw make_error("", "registration cloud grid_width/grid_height", "more than 2^31 cells");
  for (const std::uint32_t cell : cloud.grid_cells)
    if (cell >= cells) throw make_error("", "registration cloud grid_cells", "a cell lies outside the grid");
}

// The grid's point index per cell (kEmptyCell where no point was kept); a cell given twice is an error.
std::vector<std::int32_t> cell_to_point(const RegistrationCloud& cloud) {
  std::vector<std::int32_t> index(std::size_t(cloud.grid_width) * std::size_t(cloud.grid_height), kEmptyCell);
  for (std::size_t i = 0; i < cloud.grid_cells.size(); ++i) {
    std::int32_t& slot = index[cloud.grid_cells[i]];
    if (slot != kEmptyCell) throw make_error("", "registration cloud grid_cells", "two points in one cell");
    slot = std::int32_t(i);
  }
  return index;
}

// The k nearest of point i among the points of the grid window of radius r around its cell (columns
// wrap: the grid is a panorama's, periodic in azimuth), in no particular order (the fit is a sum).
std::size_t grid_neighbours(const RegistrationCloud& cloud, const std::vector<std::int32_t>& cell_index,
                            std::size_t i, int r, std::size_t k, std::vector<std::pair<double, std::uint32_t>>& scratch,
                            std::uint32_t* indices) {
  const int width = cloud.grid_width, height = cloud.grid_height;
  const int row = int(cloud.grid_cells[i] / std::uint32_t(width)), column = int(cloud.grid_cells[i] % std::uint32_t(width));
  const Eigen::Vector3d& p = cloud.points[i];
  scratch.clear();
  // The window spans at most the whole row: a narrow grid must not visit a column twice.
  const int column_radius = std::min(r, (width - 1) / 2);
  for (int dv = -r; dv <= r; ++dv) {
    const int v = row + dv;
    if (v < 0 || v >= height) continue;
    const std::int32_t* cells = cell_index.data() + std::size_t(v) * width;
    for (int du = -column_radius; du <= column_radius; ++du) {
      int u = column + du;
      if (u < 0) u += width;
      if (u >= width) u -= width;
      const std::int32_t j = cells[u];
      if (j == kEmptyCell) continue;
      scratch.emplace_back((cloud.points[std::size_t(j)] - p).squaredNorm(), std::uint32_t(j));
    }
  }
  const std::size_t found = std::min(k, scratch.size());
  // (distance, index) pairs: the k-th is unique, so the chosen set does not depend on the order.
  if (found < scratch.size()) std::nth_element(scratch.begin(), scratch.begin() + long(found) - 1, scratch.end());
  for (std::size_t j = 0; j < found; ++j) indices[j] = scratch[j].second;
  return found;
}

// Normal, curvature and GICP covariance of point i from its neighbours (which include i itself).
void fit_surface(RegistrationCloud& cloud, std::size_t i, const std::uint32_t* indices, std::size_t found,
                 const Eigen::Vector3d& viewpoint, const SurfaceOptions& options) {
  const Eigen::Vector3d& p = cloud.points[i];
  Eigen::Vector3d towards_viewpoint = viewpoint - p;
  if (towards_viewpoint.norm() < 1e-12) towards_viewpoint = Eigen::Vector3d::UnitZ();
  towards_viewpoint.normalize();
  if (found < 3) {
    cloud.normals[i] = towards_viewpoint;
    return;
  }
  // One pass over the neighbours, relative to p (offsets of centimetres: no cancellation).
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < found; ++j) {
    const Eigen::Vector3d d = cloud.points[indices[j]] - p;
    sum += d;
    outer += d * d.transpose();
  }
  const Eigen::Vector3d mean = sum / double(found);
  const Eigen::Matrix3d covariance = outer / double(found) - mean * mean.transpose();
  // The closed-form 3x3 solver (Eigen's computeDirect, several times faster than the
  // iterative one): the normal is the eigenvector of the clearly smallest eigenvalue, which
  // it resolves well; where the two in-plane eigenvalues are close their vectors are
  // arbitrary, but the plane-shaped covariance below does not depend on them.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(covariance);
  const Eigen::Vector3d values = eigen.eigenvalues().cwiseMax(0.0);  // ascending
  const Eigen::Matrix3d vectors = eigen.eigenvectors();
  Eigen::Vector3d normal = vectors.col(0);
  if (normal.dot(towards_viewpoint) < 0) normal = -normal;
  cloud.normals[i] = normal;
  const double total = values.sum();
  cloud.curvature[i] = total > 0 ? float(values[0] / total) : 0.f;
  // GICP: the point may slide within its plane but not across it: Segal et al.'s unit form
  // by default; metric_scale: scaled by the neighbourhood's in-plane variance (m^2).
  // registration.h compares the two.
  const double in_plane = options.metric_scale ? std::max(0.5 * (values[1] + values[2]), 1e-10) : 1.0;
  const Eigen::Vector3d shape(options.plane_epsilon * in_plane, in_plane, in_plane);
  cloud.surface_covariances[i] = vectors * shape.asDiagonal() * vectors.transpose();
}

}  // namespace

void prepare_surface(RegistrationCloud& cloud, const Eigen::Vector3d& viewpoint, const SurfaceOptions& options) {
  const std::size_t n = cloud.points.size();
  if (n == 0) throw make_error("", "registration cloud", "is empty");
  if (options.neighbours < 3) throw make_error("", "surface.neighbours", "must be at least 3");
  if (options.grid_radius < 1 || options.grid_radius > 16)
    throw make_error("", "surface.grid_radius", "must be in [1, 16]");
  const bool organised = !cloud.grid_cells.empty();
  std::unique_ptr<PointKdTree> tree;
  std::vector<std::int32_t> cell_index;
  if (organised) {
    check_grid(cloud);
    cell_index = cell_to_point(cloud);
  } else {
    tree = std::make_unique<PointKdTree>(cloud.points);
  }
  cloud.normals.assign(n, Eigen::Vector3d::UnitZ());
  cloud.curvature.assign(n, 0.f);
  cloud.surface_covariances.assign(n, Eigen::Matrix3d::Identity() * 1e-4);
  const std::size_t k = std::min<std::size_t>(options.neighbours, n);
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const tbb::blocked_range<std::size_t>& range) {
      std::vector<std::uint32_t> indices(k);
      std::vector<double> squared(k);
      std::vector<std::pair<double, std::uint32_t>> scratch;
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const std::size_t found =
            organised ? grid_neighbours(cloud, cell_index, i, options.grid_radius, k, scratch, indices.data())
                      : tree->knn(cloud.points[i], k, indices.data(), squared.data());
        fit_surface(cloud, i, indices.data(), found, viewpoint, options);
      }
    });
  });
}

}  // namespace panoscan
