// Accuracy of a reconstructed cloud against the ground-truth mesh (docs/ARCHITECTURE.md §13, paper Tables 1-5).
//
// Accuracy side: every reconstructed point's exact distance to the mesh (MeshDistance). The
// paper's figure is the RMSE over all points; we also give mean, median, p90, p99 and max, and
// optionally a second RMSE over the points within a cut-off, which is always reported together
// with the cut-off and the number of points it removed.
//
// Completeness side (beyond the paper; Tanks-and-Temples-style): the ground-truth surface is
// sampled uniformly by area, the samples the scanning positions cannot see are dropped (see
// VisibilityOptions), and each remaining sample's distance to the nearest reconstructed point is
// measured. At a threshold tau:
//   accuracy(tau)     = fraction of reconstructed points within tau of the mesh   (precision)
//   completeness(tau) = fraction of visible samples within tau of the cloud       (recall)
//   F(tau)            = 2 * accuracy * completeness / (accuracy + completeness)
// "Within" means d < tau.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "panoscan/core/point_cloud.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/surface_sampling.h"

namespace panoscan::eval {

class MeshDistance;

struct CompletenessOptions {
  bool enabled = true;
  double samples_per_m2 = 4000.0;     // ~1.6 cm spacing
  std::size_t max_samples = 2000000;  // cap for very large meshes
  std::uint64_t seed = 1;
  std::vector<std::uint8_t> triangle_mask;  // empty = all triangles; else 1 per triangle
  VisibilityOptions visibility;             // no viewpoints = the whole (masked) surface
};

struct CloudMetricsOptions {
  std::vector<double> thresholds_m = {0.01, 0.02, 0.05};
  double outlier_cutoff_m = 0.0;  // > 0: also report the RMSE of the points with d <= cut-off
  CompletenessOptions completeness;

  // Throws Error naming `origin` and the field for values out of range.
  void check(const std::string& origin = "<cloud evaluation options>") const;
};

struct ThresholdScore {
  double threshold_m = 0.0;
  double accuracy = 0.0;      // fraction in [0, 1]
  double completeness = 0.0;  // fraction in [0, 1]; NaN without completeness
  double f_score = 0.0;       // NaN without completeness
};

struct CloudMetrics {
  ErrorStats accuracy_m;  // all points, metres

  double outlier_cutoff_m = 0.0;  // 0 = no second figure
  ErrorStats accuracy_within_cutoff_m;
  std::size_t points_beyond_cutoff = 0;

  bool has_completeness = false;
  std::size_t surface_samples = 0;  // drawn on the (masked) surface
  std::size_t visible_samples = 0;  // kept by the visibility test
  double sampled_area_m2 = 0.0;     // area of the (masked) surface
  double visible_area_m2 = 0.0;     // sampled_area_m2 * visible / drawn (an estimate)
  ErrorStats completeness_m;        // visible samples -> nearest point, metres

  std::vector<ThresholdScore> scores;  // one per threshold

  double seconds_accuracy = 0.0, seconds_completeness = 0.0;  // wall-clock time of each side
};

// Throws Error naming `cloud_origin` for an empty cloud or a non-finite point.
// `point_distances`, if given, receives every point's distance (for colouring and histograms);
// `sample_distances` the visible samples' distances to the cloud.
CloudMetrics evaluate_cloud(const MeshDistance& mesh, const PointCloud& cloud, const std::string& cloud_origin,
                            const CloudMetricsOptions& options, std::vector<double>* point_distances = nullptr,
                            std::vector<double>* sample_distances = nullptr);

}  // namespace panoscan::eval
