// Area-uniform surface samples and their visibility from the scanning positions.

#include "panoscan/eval/surface_sampling.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/eval/mesh_distance.h"

namespace panoscan::eval {

namespace {

// Samples are drawn in blocks of this size, block b from RandomStream(seed, lane b): the result
// depends on the seed only, not on how blocks are spread over threads.
constexpr std::size_t kSamplesPerBlock = 4096;

Eigen::Vector3d corner(const TriangleMesh& mesh, std::size_t triangle, int k) {
  return mesh.vertices[mesh.triangles[triangle][k]].cast<double>();
}

}  // namespace

std::vector<SurfaceSample> sample_surface_uniform(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                                  const std::vector<std::uint8_t>& triangle_mask,
                                                  const std::string& origin) {
  const std::size_t num_triangles = mesh.triangles.size();
  if (num_triangles == 0) throw make_error(origin, "triangles", "the mesh has no triangles");
  if (!triangle_mask.empty() && triangle_mask.size() != num_triangles)
    throw make_error(
        origin, "triangle mask",
        std::to_string(triangle_mask.size()) + " entries for " + std::to_string(num_triangles) + " triangles");
  // Cumulative area: a uniform draw in [0, total) picks a triangle with probability area / total.
  std::vector<double> cumulative_area(num_triangles);
  double total = 0.0;
  for (std::size_t t = 0; t < num_triangles; ++t) {
    if (triangle_mask.empty() || triangle_mask[t]) {
      const Eigen::Vector3d a = corner(mesh, t, 0), b = corner(mesh, t, 1), c = corner(mesh, t, 2);
      total += 0.5 * (b - a).cross(c - a).norm();
    }
    cumulative_area[t] = total;
  }
  if (!(total > 0)) throw make_error(origin, "triangle mask", "selects no surface area to sample");

  std::vector<SurfaceSample> samples(count);
  const std::size_t blocks = (count + kSamplesPerBlock - 1) / kSamplesPerBlock;
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t block) {
    RandomStream random(seed, 0, 0, RandomPurpose::kGeneric, static_cast<std::int64_t>(block));
    const std::size_t end = std::min(count, (block + 1) * kSamplesPerBlock);
    for (std::size_t i = block * kSamplesPerBlock; i < end; ++i) {
      const double pick = random.uniform(0.0, total);
      std::size_t t = static_cast<std::size_t>(std::upper_bound(cumulative_area.begin(), cumulative_area.end(), pick) -
                                               cumulative_area.begin());
      t = std::min(t, num_triangles - 1);
      // Uniform point in a triangle (Osada et al. 2002): sqrt(r1) spreads the mass evenly from
      // the corner a to the opposite edge.
      const double s = std::sqrt(random.uniform());
      const double r = random.uniform();
      const Eigen::Vector3d a = corner(mesh, t, 0), b = corner(mesh, t, 1), c = corner(mesh, t, 2);
      samples[i].point = (1.0 - s) * a + s * (1.0 - r) * b + s * r * c;
      samples[i].triangle = static_cast<int>(t);
    }
  });
  return samples;
}

std::vector<std::uint8_t> visible_samples(const MeshDistance& mesh, const std::vector<SurfaceSample>& samples,
                                          const VisibilityOptions& options) {
  std::vector<std::uint8_t> visible(samples.size(), 1);
  if (options.viewpoints.empty()) return visible;
  const TriangleMesh& triangles = mesh.mesh();
  const double min_cos_incidence = std::cos(deg2rad(options.max_incidence_deg));
  const double max_sin_elevation = std::sin(deg2rad(std::min(options.max_abs_elevation_deg, 90.0)));
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, samples.size(), 256), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const SurfaceSample& sample = samples[i];
          const std::size_t t = static_cast<std::size_t>(sample.triangle);
          const Eigen::Vector3d a = corner(triangles, t, 0), b = corner(triangles, t, 1), c = corner(triangles, t, 2);
          const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
          bool seen = false;
          for (const Eigen::Vector3d& viewpoint : options.viewpoints) {
            const Eigen::Vector3d sight = sample.point - viewpoint;
            const double range_m = sight.norm();
            if (range_m < options.min_range_m || range_m > options.max_range_m || range_m <= 0) continue;
            const Eigen::Vector3d unit = sight / range_m;
            // A degenerate triangle has a NaN normal: the comparison fails, not visible.
            if (!(std::abs(unit.dot(normal)) >= min_cos_incidence)) continue;
            if (std::abs(unit.z()) > max_sin_elevation) continue;
            if (mesh.segment_blocked(viewpoint, sample.point, options.end_margin_m)) continue;
            seen = true;
            break;
          }
          visible[i] = seen ? 1 : 0;
        }
      });
  return visible;
}

}  // namespace panoscan::eval
