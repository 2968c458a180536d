// Accuracy, completeness and F-score of a reconstructed cloud (definitions in cloud_metrics.h).

#include "panoscan/core/timer.h"
#include "panoscan/eval/cloud_metrics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/eval/point_set_distance.h"

namespace panoscan::eval {

namespace {

double fraction_below(const std::vector<double>& values, double threshold) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t below =
      static_cast<std::size_t>(std::count_if(values.begin(), values.end(), [&](double v) { return v < threshold; }));
  return static_cast<double>(below) / static_cast<double>(values.size());
}

}  // namespace

void CloudMetricsOptions::check(const std::string& origin) const {
  if (thresholds_m.empty()) throw make_error(origin, "thresholds_m", "needs at least one threshold");
  for (double t : thresholds_m)
    if (!(t > 0) || !std::isfinite(t)) throw make_error(origin, "thresholds_m", "thresholds must be positive");
  if (!(outlier_cutoff_m >= 0) || !std::isfinite(outlier_cutoff_m))
    throw make_error(origin, "outlier_cutoff_m", "must be >= 0 (0 = off)");
  const CompletenessOptions& c = completeness;
  if (c.enabled) {
    if (!(c.samples_per_m2 > 0) || !std::isfinite(c.samples_per_m2))
      throw make_error(origin, "completeness.samples_per_m2", "must be positive");
    if (c.max_samples == 0) throw make_error(origin, "completeness.max_samples", "must be positive");
    const VisibilityOptions& v = c.visibility;
    for (const auto& p : v.viewpoints)
      if (!p.allFinite()) throw make_error(origin, "visibility.viewpoints", "non-finite coordinate");
    if (!(v.min_range_m >= 0) || !(v.max_range_m > v.min_range_m))
      throw make_error(origin, "visibility.max_range_m", "needs 0 <= min_range_m < max_range_m");
    if (!(v.max_incidence_deg > 0 && v.max_incidence_deg <= 90))
      throw make_error(origin, "visibility.max_incidence_deg", "must be in (0, 90]");
    if (!(v.max_abs_elevation_deg > 0 && v.max_abs_elevation_deg <= 90))
      throw make_error(origin, "visibility.max_abs_elevation_deg", "must be in (0, 90]");
    if (!(v.end_margin_m >= 0)) throw make_error(origin, "visibility.end_margin_m", "must be >= 0");
  }
}

CloudMetrics evaluate_cloud(const MeshDistance& mesh, const PointCloud& cloud, const std::string& cloud_origin,
                            const CloudMetricsOptions& options, std::vector<double>* point_distances,
                            std::vector<double>* sample_distances) {
  options.check();
  if (cloud.empty()) throw make_error(cloud_origin, "", "the cloud has no points: nothing to evaluate");
  CloudMetrics metrics;

  using Clock = std::chrono::steady_clock;
  auto start = Clock::now();

  // Accuracy: exact point-to-mesh distances of every point.
  std::vector<double> distances = mesh.distances(cloud.positions, cloud_origin);
  metrics.accuracy_m = summarize_errors(distances);
  if (options.outlier_cutoff_m > 0) {
    metrics.outlier_cutoff_m = options.outlier_cutoff_m;
    std::vector<double> kept;
    kept.reserve(distances.size());
    for (double d : distances)
      if (d <= options.outlier_cutoff_m) kept.push_back(d);
    metrics.points_beyond_cutoff = distances.size() - kept.size();
    metrics.accuracy_within_cutoff_m = summarize_errors(std::move(kept));
  }

  metrics.seconds_accuracy = seconds_since(start);
  start = Clock::now();

  // Completeness: visible ground-truth samples -> nearest reconstructed point.
  std::vector<double> completeness_distances;
  const CompletenessOptions& c = options.completeness;
  if (c.enabled) {
    metrics.has_completeness = true;
    const TriangleMesh& triangles = mesh.mesh();
    double area = 0.0;
    for (std::size_t t = 0; t < triangles.triangles.size(); ++t) {
      if (!c.triangle_mask.empty() && t < c.triangle_mask.size() && !c.triangle_mask[t]) continue;
      const Eigen::Vector3d a = triangles.vertices[triangles.triangles[t][0]].cast<double>();
      const Eigen::Vector3d b = triangles.vertices[triangles.triangles[t][1]].cast<double>();
      const Eigen::Vector3d d = triangles.vertices[triangles.triangles[t][2]].cast<double>();
      area += 0.5 * (b - a).cross(d - a).norm();
    }
    metrics.sampled_area_m2 = area;
    const double wanted = std::ceil(area * c.samples_per_m2);
    const std::size_t count = static_cast<std::size_t>(std::clamp(wanted, 1.0, static_cast<double>(c.max_samples)));
    const std::vector<SurfaceSample> samples =
        sample_surface_uniform(triangles, count, c.seed, c.triangle_mask, mesh.origin());
    const std::vector<std::uint8_t> visible = visible_samples(mesh, samples, c.visibility);
    std::vector<Eigen::Vector3d> visible_points;
    visible_points.reserve(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i)
      if (visible[i]) visible_points.push_back(samples[i].point);
    metrics.surface_samples = samples.size();
    metrics.visible_samples = visible_points.size();
    metrics.visible_area_m2 = area * static_cast<double>(visible_points.size()) / static_cast<double>(samples.size());
    if (visible_points.empty())
      log_warn(mesh.origin() + ": no ground-truth sample is visible from the viewpoints; completeness is undefined");
    const PointSetDistance cloud_index(cloud.positions);
    completeness_distances = cloud_index.nearest_distances(visible_points);
    metrics.completeness_m = summarize_errors(completeness_distances);
    metrics.seconds_completeness = seconds_since(start);
  }

  for (double threshold : options.thresholds_m) {
    ThresholdScore score;
    score.threshold_m = threshold;
    score.accuracy = fraction_below(distances, threshold);
    if (metrics.has_completeness) {
      score.completeness = fraction_below(completeness_distances, threshold);
      const double sum = score.accuracy + score.completeness;
      score.f_score = sum > 0 ? 2.0 * score.accuracy * score.completeness / sum : 0.0;
      if (std::isnan(score.completeness)) score.f_score = score.completeness;
    } else {
      score.completeness = score.f_score = std::numeric_limits<double>::quiet_NaN();
    }
    metrics.scores.push_back(score);
  }
  if (point_distances) *point_distances = std::move(distances);
  if (sample_distances) *sample_distances = std::move(completeness_distances);
  return metrics;
}

}  // namespace panoscan::eval
