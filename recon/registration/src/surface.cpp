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

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PANOSCAN_SURFACE_AVX512 1
#endif

#include "panoscan/core/cpu_features.h"
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
                            int r, std::size_t k, SmallestKeysKernel kernel, WindowScratch& scratch,
                            std::uint32_t* indices) {
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
  const std::size_t found = smallest_keys(keys, count, k, scratch.chosen.data(), scratch.selection, kernel);
  for (std::size_t j = 0; j < found; ++j) indices[j] = candidates[scratch.chosen[j]];
  return found;
}

#ifdef PANOSCAN_SURFACE_AVX512
// The cloud's coordinates laid out as its grid, one plane per axis (empty cells hold zeros): a window
// row is then 7 consecutive doubles per axis, where gathers from the points (slow on Zen 4) made this
// path slower than the scalar one.
struct GridPlanes {
  std::vector<double> x, y, z;
  explicit GridPlanes(const RegistrationCloud& cloud) {
    const std::size_t cells = std::size_t(cloud.grid_width) * std::size_t(cloud.grid_height);
    x.assign(cells, 0.0);
    y.assign(cells, 0.0);
    z.assign(cells, 0.0);
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      const std::uint32_t cell = cloud.grid_cells[i];
      x[cell] = cloud.points[i].x(), y[cell] = cloud.points[i].y(), z[cell] = cloud.points[i].z();
    }
  }
};

// grid_neighbours for radius 3 around a cell at least 3 columns from either edge (no wrap), on
// AVX-512: each window row's 7 cells in one vector (slot 8 row + column; the 8th lane unused), their
// keys as window_key makes them but with the slot for the position (it orders as the window position
// does, so the chosen set is the same), and the 7 vectors handed to smallest_keys_mask in place. The
// distances are rounded as the scalar path rounds them (no contraction into FMAs): the two paths give
// the same bits.
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
// GCC 12's AVX-512 intrinsics pass _mm256_undefined_pd() as the unused merge source, which it then
// reports as "may be used uninitialized" (GCC bug 105593, as in core/src/random.cpp).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
__attribute__((target("avx512f,avx512dq,bmi2"))) std::size_t interior_neighbours_avx512(
    const RegistrationCloud& cloud, const GridPlanes& planes, const std::vector<std::int32_t>& cell_index, int row,
    int column, const Eigen::Vector3d& p, std::size_t k, std::uint32_t* indices) {
  alignas(64) std::uint64_t keys[64];
  alignas(64) std::int32_t points_in_slots[64];
  const __m512d px = _mm512_set1_pd(p.x()), py = _mm512_set1_pd(p.y()), pz = _mm512_set1_pd(p.z());
  const __m512i kept_bits = _mm512_set1_epi64(~static_cast<long long>((1u << kPositionBits) - 1));
  const __m512i lane = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
  std::uint64_t in_play = 0;
  for (int window_row = 0; window_row < 7; ++window_row) {
    const int v = row + window_row - 3;
    if (v < 0 || v >= cloud.grid_height) continue;
    const std::size_t first = std::size_t(v) * std::size_t(cloud.grid_width) + std::size_t(column - 3);
    const __m512i cells16 = _mm512_maskz_loadu_epi32(0x7F, cell_index.data() + first);
    const __mmask8 valid = __mmask8(_mm512_mask_cmpneq_epi32_mask(0x7F, cells16, _mm512_set1_epi32(kEmptyCell)));
    _mm256_store_si256(reinterpret_cast<__m256i*>(points_in_slots + 8 * window_row), _mm512_castsi512_si256(cells16));
    const __m512d dx = _mm512_sub_pd(_mm512_maskz_loadu_pd(0x7F, planes.x.data() + first), px);
    const __m512d dy = _mm512_sub_pd(_mm512_maskz_loadu_pd(0x7F, planes.y.data() + first), py);
    const __m512d dz = _mm512_sub_pd(_mm512_maskz_loadu_pd(0x7F, planes.z.data() + first), pz);
    // (dx^2 + dy^2) + dz^2: Eigen's order for squaredNorm of a 3-vector.
    const __m512d squared =
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)), _mm512_mul_pd(dz, dz));
    const __m512i slot = _mm512_add_epi64(lane, _mm512_set1_epi64(8 * window_row));
    const __m512i key = _mm512_or_si512(_mm512_and_si512(_mm512_castpd_si512(squared), kept_bits), slot);
    _mm512_store_si512(keys + 8 * window_row, key);
    in_play |= std::uint64_t(valid) << (8 * window_row);
  }
  std::size_t found = 0;
  for (std::uint64_t chosen = smallest_keys_mask(keys, in_play, k); chosen != 0; chosen &= chosen - 1)
    indices[found++] = std::uint32_t(points_in_slots[__builtin_ctzll(chosen)]);
  return found;
}
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

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

// A symmetric 3x3 matrix by its six distinct entries, in plain scalars: Eigen's 3x3 expressions
// spilled to the stack in this hot path.
struct Symmetric3 {
  double xx, xy, xz, yy, yz, zz;
};

SmallestEigen smallest_eigen(const Symmetric3& a, const Eigen::Vector3d& fallback) {
  const double shift = (a.xx + a.yy + a.zz) / 3.0;
  double b00 = a.xx - shift, b11 = a.yy - shift, b22 = a.zz - shift, b01 = a.xy, b02 = a.xz, b12 = a.yz;
  const double scale =
      std::max({std::abs(b00), std::abs(b11), std::abs(b22), std::abs(b01), std::abs(b02), std::abs(b12)});
  if (!(scale > 0)) return {Eigen::Vector3d::Constant(shift), fallback};
  const double inverse_scale = 1.0 / scale;
  b00 *= inverse_scale, b11 *= inverse_scale, b22 *= inverse_scale;
  b01 *= inverse_scale, b02 *= inverse_scale, b12 *= inverse_scale;
  // B has trace 0: x^3 - 3 p x - 2 q = 0 with p = tr(B^2) / 6, q = det(B) / 2, roots
  // 2 sqrt(p) cos(phi + 2 pi j / 3) with phi = acos(q / p^(3/2)) / 3.
  const double p = (b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (b01 * b01 + b02 * b02 + b12 * b12)) / 6.0;
  const double q =
      0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02));
  const double sqrt_p = std::sqrt(p);
  const double phi = std::acos(std::clamp(q / (p * sqrt_p), -1.0, 1.0)) / 3.0;
  const double largest = 2.0 * sqrt_p * std::cos(phi);
  const double smallest = 2.0 * sqrt_p * std::cos(phi + 2.0 * M_PI / 3.0);
  const double middle = -largest - smallest;
  SmallestEigen result{Eigen::Vector3d(smallest, middle, largest) * scale + Eigen::Vector3d::Constant(shift), fallback};
  // Rows of B - lambda_0 I (symmetric: r0 = (d0, b01, b02), r1 = (b01, d1, b12), r2 = (b02, b12, d2)).
  const double d0 = b00 - smallest, d1 = b11 - smallest, d2 = b22 - smallest;
  const Eigen::Vector3d c01(b01 * b12 - b02 * d1, b02 * b01 - d0 * b12, d0 * d1 - b01 * b01);  // r0 x r1
  const Eigen::Vector3d c02(b01 * d2 - b02 * b12, b02 * b02 - d0 * d2, d0 * b12 - b01 * b02);  // r0 x r2
  const Eigen::Vector3d c12(d1 * d2 - b12 * b12, b12 * b02 - b01 * d2, b01 * b12 - d1 * b02);  // r1 x r2
  const double n01 = c01.squaredNorm(), n02 = c02.squaredNorm(), n12 = c12.squaredNorm();
  // B is scaled to entries of at most 1, so these thresholds are relative ones.
  const double largest_cross = std::max({n01, n02, n12});
  if (largest_cross > 1e-24) {
    const Eigen::Vector3d& c = n01 == largest_cross ? c01 : (n02 == largest_cross ? c02 : c12);
    result.vector = c / std::sqrt(largest_cross);
    return result;
  }
  const Eigen::Vector3d r0(d0, b01, b02), r1(b01, d1, b12), r2(b02, b12, d2);
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
  const double inverse_count = 1.0 / double(found);
  const double mx = sx * inverse_count, my = sy * inverse_count, mz = sz * inverse_count;
  const Symmetric3 covariance{sxx * inverse_count - mx * mx, sxy * inverse_count - mx * my,
                              sxz * inverse_count - mx * mz, syy * inverse_count - my * my,
                              syz * inverse_count - my * mz, szz * inverse_count - mz * mz};
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
  const double across = in_plane * (1.0 - options.plane_epsilon);
  Eigen::Matrix3d& shape = cloud.surface_covariances[i];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) shape(r, c) = (r == c ? in_plane : 0.0) - across * normal[r] * normal[c];
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
  const SmallestKeysKernel selection_kernel =
      options.vector_kernels ? SmallestKeysKernel::kFastest : SmallestKeysKernel::kNthElement;
#ifdef PANOSCAN_SURFACE_AVX512
  // The vector window: radius 3 (7 columns in a vector), and the same CPU features as the selection's.
  const bool vector_window =
      options.vector_kernels && organised && options.grid_radius == 3 && cpu::has_avx512dq() && cpu::has_bmi2();
  std::unique_ptr<GridPlanes> planes;
  if (vector_window) planes = std::make_unique<GridPlanes>(cloud);
#endif
  // Point i's neighbours into `indices`; returns how many.
  auto neighbours = [&](std::size_t i, std::uint32_t* indices, double* squared, WindowScratch& scratch) {
    if (!organised) return tree->knn(cloud.points[i], k, indices, squared);
#ifdef PANOSCAN_SURFACE_AVX512
    const int row = int(cloud.grid_cells[i] / std::uint32_t(cloud.grid_width));
    const int column = int(cloud.grid_cells[i] % std::uint32_t(cloud.grid_width));
    if (vector_window && column >= 3 && column + 3 < cloud.grid_width)
      return interior_neighbours_avx512(cloud, *planes, cell_index, row, column, cloud.points[i], k, indices);
#endif
    return grid_neighbours(cloud, cell_index, i, options.grid_radius, k, selection_kernel, scratch, indices);
  };
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const tbb::blocked_range<std::size_t>& range) {
      std::vector<std::uint32_t> indices(k);
      std::vector<double> squared(k);
      WindowScratch scratch;
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        fit_surface(cloud, i, indices.data(), neighbours(i, indices.data(), squared.data(), scratch), viewpoint,
                    options);
      }
    });
  });
}

}  // namespace panoscan
