// Uniform samples of a mesh's surface and their visibility from viewpoints: the ground truth side
// of the completeness metric ("each ground-truth sample's distance to the nearest reconstructed
// point", restricted to the surface the scanning positions can see).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/mesh.h"

namespace panoscan::eval {

class MeshDistance;

struct SurfaceSample {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int triangle = -1;
};

// `count` samples distributed uniformly by area over the triangles whose mask entry is non-zero
// (all triangles if the mask is empty). Deterministic for a seed, whatever the thread count:
// samples are drawn in fixed blocks, each from its own RandomStream keyed by the block index.
// Throws Error naming `origin` if the mask has the wrong length or selects no area.
std::vector<SurfaceSample> sample_surface_uniform(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                                  const std::vector<std::uint8_t>& triangle_mask = {},
                                                  const std::string& origin = "ground-truth mesh");

// A sample is visible if, from at least one viewpoint, (1) its distance lies in
// [min_range_m, max_range_m], (2) the angle between the line of sight and the triangle's normal
// (either side) is at most max_incidence_deg, (3) the line of sight's elevation above the
// horizontal (z up) is within +-max_abs_elevation_deg, and (4) no triangle blocks the line of
// sight (an Embree occlusion ray that stops end_margin_m short of the sample, so that the
// sample's own triangle does not count). Defaults follow the simulated sensor (docs/ARCHITECTURE.md §4.1, §6.5).
struct VisibilityOptions {
  std::vector<Eigen::Vector3d> viewpoints;  // empty: every sample counts as visible
  double min_range_m = 0.0;
  double max_range_m = 8.0;
  double max_incidence_deg = 82.0;
  double max_abs_elevation_deg = 90.0;  // 90 = no limit; the default rig sees about +-67.5
  double end_margin_m = 1e-3;
};

// One flag per sample (1 = visible), computed in parallel.
std::vector<std::uint8_t> visible_samples(const MeshDistance& mesh, const std::vector<SurfaceSample>& samples,
                                          const VisibilityOptions& options);

}  // namespace panoscan::eval
