// Local surface of every point from its k nearest neighbours: the normal, the curvature and
// Generalized-ICP's plane-shaped covariance (Segal et al. 2009, §III-B). The neighbours come from a
// kd-tree, or, for a cloud sampled from a grid (RegistrationCloud::grid_cells), from the grid
// window around each point.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/core/smallest_keys.h"
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

// Reused per thread by grid_neighbours.
struct WindowScratch {
  std::vector<std::uint32_t> candidates;  // point indices, in window order
  std::vector<std::uint64_t> keys;        // their selection keys, the same order
  std::vector<std::uint32_t> chosen;      // positions in the window of the k nearest
  std::vector<std::uint64_t> selection;   // smallest_keys' own scratch
};

// A window candidate's key: its squared distance's bits (non-negative doubles order as their bit
// patterns) with the lowest kPositionBits replaced by its position in the window. The keys are then
// distinct, and order as the distances do up to a relative 2^-41, ties going to the earlier
// position; the chosen set does not depend on how it is selected.
constexpr int kPositionBits = 11;
static_assert((2 * 16 + 1) * (2 * 16 + 1) < (1 << kPositionBits), "grid_radius 16's window needs more bits");

std::uint64_t window_key(double squared_distance, std::size_t position) {
  std::uint64_t bits;
  std::memcpy(&bits, &squared_distance, sizeof bits);
  return (bits & ~((std::uint64_t(1) << kPositionBits) - 1)) | std::uint64_t(position);
}

// The k nearest of point i among the points of the grid window of radius r around its cell (columns
// wrap: the grid is a panorama's, periodic in azimuth), in window order (row by row, so the fit's
// sums do not depend on how they were selected).
std::size_t grid_neighbours(const RegistrationCloud& cloud, const std::vector<std::int32_t>& cell_index, std::size_t i,
                            int r, std::size_t k, WindowScratch& scratch, std::uint32_t* indices) {
  const int width = cloud.grid_width, height = cloud.grid_height;
  const int row = int(cloud.grid_cells[i] / std::uint32_t(width)), column = int(cloud.grid_cells[i] % std::uint32_t(width));
  const Eigen::Vector3d& p = cloud.points[i];
  // The window spans at most the whole row: a narrow grid must not visit a column twice.
  const int column_radius = std::min(r, (width - 1) / 2);
  const std::size_t window = std::size_t(2 * r + 1) * std::size_t(2 * column_radius + 1);
  if (scratch.keys.size() < window) {
    scratch.keys.resize(window);
    scratch.candidates.resize(window);
    scratch.chosen.resize(window);
  }
  std::uint64_t* keys = scratch.keys.data();
  std::uint32_t* candidates = scratch.candidates.data();
  std::size_t count = 0;
  const bool wraps = column - column_radius < 0 || column + column_radius >= width;
  for (int dv = -r; dv <= r; ++dv) {
    const int v = row + dv;
    if (v < 0 || v >= height) continue;
    const std::int32_t* cells = cell_index.data() + std::size_t(v) * width;
    for (int du = -column_radius; du <= column_radius; ++du) {
      int u = column + du;
      if (wraps) u = u < 0 ? u + width : (u >= width ? u - width : u);
      const std::int32_t j = cells[u];
      if (j == kEmptyCell) continue;
      keys[count] = window_key((cloud.points[std::size_t(j)] - p).squaredNorm(), count);
      candidates[count++] = std::uint32_t(j);
    }
  }
  const std::size_t found = smallest_keys(keys, count, k, scratch.chosen.data(), scratch.selection);
  for (std::size_t j = 0; j < found; ++j) indices[j] = candidates[scratch.chosen[j]];
  return found;
}

// The eigenvalues (ascending) of a symmetric 3x3 matrix and the unit eigenvector of the smallest,
// in closed form (Smith 1961: the characteristic cubic of the shifted, scaled matrix by its
// trigonometric roots). Only the smallest eigenvalue's vector is needed: the plane-shaped covariance
// depends on the normal alone. Its vector is the cross product of two rows of A - lambda_0 I, the
// longest of the three: accurate whenever lambda_0 is apart from lambda_1, which is when a normal
// exists at all. With lambda_0 = lambda_1 (a line of points) it is any vector orthogonal to the
// remaining row; with all three equal (one point repeated, or no shape) `fallback`.
struct SmallestEigen {
  Eigen::Vector3d values;
  Eigen::Vector3d vector;
};

SmallestEigen smallest_eigen(const Eigen::Matrix3d& a, const Eigen::Vector3d& fallback) {
  const double shift = a.trace() / 3.0;
  Eigen::Matrix3d b = a;
  b.diagonal().array() -= shift;
  const double scale = b.cwiseAbs().maxCoeff();
  if (!(scale > 0)) return {Eigen::Vector3d::Constant(shift), fallback};
  b /= scale;
  // B has trace 0: x^3 - 3 p x - 2 q = 0 with p = tr(B^2) / 6, q = det(B) / 2, roots
  // 2 sqrt(p) cos(phi + 2 pi j / 3) with phi = acos(q / p^(3/2)) / 3.
  const double p = (b.cwiseAbs2().sum()) / 6.0;
  const double q = 0.5 * b.determinant();
  const double sqrt_p = std::sqrt(p);
  const double phi = std::acos(std::clamp(q / (p * sqrt_p), -1.0, 1.0)) / 3.0;
  const double largest = 2.0 * sqrt_p * std::cos(phi);
  const double smallest = 2.0 * sqrt_p * std::cos(phi + 2.0 * M_PI / 3.0);
  const double middle = -largest - smallest;
  SmallestEigen result{Eigen::Vector3d(smallest, middle, largest) * scale + Eigen::Vector3d::Constant(shift), fallback};
  b.diagonal().array() -= smallest;
  const Eigen::Vector3d r0 = b.row(0), r1 = b.row(1), r2 = b.row(2);
  const Eigen::Vector3d c01 = r0.cross(r1), c02 = r0.cross(r2), c12 = r1.cross(r2);
  const double n01 = c01.squaredNorm(), n02 = c02.squaredNorm(), n12 = c12.squaredNorm();
  // B is scaled to entries of at most 1, so these thresholds are relative ones.
  const double largest_cross = std::max({n01, n02, n12});
  if (largest_cross > 1e-24) {
    const Eigen::Vector3d& c = n01 == largest_cross ? c01 : (n02 == largest_cross ? c02 : c12);
    result.vector = c / std::sqrt(largest_cross);
    return result;
  }
  const double m0 = r0.squaredNorm(), m1 = r1.squaredNorm(), m2 = r2.squaredNorm();
  const double longest_row = std::max({m0, m1, m2});
  if (longest_row > 1e-24) result.vector = (m0 == longest_row ? r0 : (m1 == longest_row ? r1 : r2)).unitOrthogonal();
  return result;
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
  // One pass over the neighbours, relative to p (offsets of centimetres: no cancellation). The
  // six distinct moments in scalars: Eigen's `outer += d * d^T` spilled its 3x3 accumulator to
  // the stack each step and stalled on store forwarding (half of this function's time).
  double sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;
  for (std::size_t j = 0; j < found; ++j) {
    const Eigen::Vector3d& q = cloud.points[indices[j]];
    const double dx = q.x() - p.x(), dy = q.y() - p.y(), dz = q.z() - p.z();
    sx += dx, sy += dy, sz += dz;
    sxx += dx * dx, sxy += dx * dy, sxz += dx * dz;
    syy += dy * dy, syz += dy * dz, szz += dz * dz;
  }
  const double count = double(found);
  const Eigen::Vector3d mean = Eigen::Vector3d(sx, sy, sz) / count;
  Eigen::Matrix3d covariance;
  covariance << sxx, sxy, sxz, sxy, syy, syz, sxz, syz, szz;
  covariance = covariance / count - mean * mean.transpose();
  const SmallestEigen eigen = smallest_eigen(covariance, towards_viewpoint);
  const Eigen::Vector3d values = eigen.values.cwiseMax(0.0);  // ascending
  Eigen::Vector3d normal = eigen.vector;
  if (normal.dot(towards_viewpoint) < 0) normal = -normal;
  cloud.normals[i] = normal;
  const double total = values.sum();
  cloud.curvature[i] = total > 0 ? float(values[0] / total) : 0.f;
  // GICP: the point may slide within its plane but not across it: Segal et al.'s unit form
  // U diag(eps, 1, 1) U^T = I - (1 - eps) n n^T by default; metric_scale: scaled by the
  // neighbourhood's in-plane variance (m^2). registration.h compares the two.
  const double in_plane = options.metric_scale ? std::max(0.5 * (values[1] + values[2]), 1e-10) : 1.0;
  cloud.surface_covariances[i] =
      in_plane * (Eigen::Matrix3d::Identity() - (1.0 - options.plane_epsilon) * normal * normal.transpose());
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
      WindowScratch scratch;
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
