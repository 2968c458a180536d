// `panoscan eval cloud`: files in, report out (text, JSON, error-coloured PLY).

#include "panoscan/core/timer.h"
#include "panoscan/eval/cloud_evaluation.h"

#include "panoscan/core/pose_json.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/task_arena.h>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/version.h"
#include "panoscan/core/log.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/eval/report.h"

namespace panoscan::eval {

namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json stats_json(const ErrorStats& s) {
  // NaN (no values) is written as null by nlohmann::json.
  return {{"count", s.count},        {"rmse_m", s.rmse},
          {"mean_m", s.mean},        {"median_m", s.median},
          {"p90_m", s.p90},          {"p99_m", s.p99},
          {"max_m", s.max},          {"rmse_mm", 1e3 * s.rmse},
          {"mean_mm", 1e3 * s.mean}, {"median_mm", 1e3 * s.median}};
}

nlohmann::json histogram_json(const Histogram& h) {
  return {{"bin_width_m", h.bin_width}, {"counts", h.counts}, {"overflow", h.overflow}};
}

std::string mm(double metres) { return std::isnan(metres) ? std::string("n/a") : fmt::format("{:.3f}", 1e3 * metres); }
std::string percent(double fraction) {
  return std::isnan(fraction) ? std::string("n/a") : fmt::format("{:.1f} %", 100.0 * fraction);
}

std::string stats_line(const ErrorStats& s) {
  return fmt::format("RMSE {} mm, mean {} mm, median {} mm, p90 {} mm, p99 {} mm, max {} mm", mm(s.rmse), mm(s.mean),
                     mm(s.median), mm(s.p90), mm(s.p99), mm(s.max));
}

Eigen::Vector3d mean_camera_centre(const std::filesystem::path& trajectory_path) {
  const std::vector<StampedPose> poses = read_tum_trajectory(trajectory_path);
  if (poses.empty()) throw make_error(trajectory_path.string(), "", "the trajectory has no poses (viewpoints)");
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& pose : poses) sum += pose.world_from_cam.translation();
  return sum / static_cast<double>(poses.size());
}

}  // namespace

CloudEvalOptions cloud_eval_options_from_config(Config& config) {
  CloudEvalOptions options;
  CloudMetricsOptions& m = options.metrics;
  m.thresholds_m = config.get_doubles("thresholds_m", m.thresholds_m, 0);
  m.outlier_cutoff_m = config.get_double("outlier_cutoff_m", m.outlier_cutoff_m, 0.0, 1e3);
  options.min_share_near_mesh = config.get_double("min_share_near_mesh", options.min_share_near_mesh, 0.0, 1.0);
  CompletenessOptions& c = m.completeness;
  c.enabled = config.get_bool("completeness.enabled", c.enabled);
  c.samples_per_m2 = config.get_double("completeness.samples_per_m2", c.samples_per_m2, 1.0, 1e8);
  const std::uint64_t max_samples = config.get_u64("completeness.max_samples", c.max_samples);
  if (max_samples == 0 || max_samples > 500000000ull)
    throw make_error(config.origin(), "completeness.max_samples", "must be in 1 .. 500000000");
  c.max_samples = static_cast<std::size_t>(max_samples);
  c.seed = config.get_u64("completeness.seed", c.seed);
  VisibilityOptions& v = c.visibility;
  const std::vector<double> coordinates = config.get_doubles("visibility.viewpoints", {}, 0);
  if (coordinates.size() % 3 != 0)
    throw make_error(config.origin(), "visibility.viewpoints", "expected x, y, z triplets (a multiple of 3 numbers)");
  for (std::size_t i = 0; i < coordinates.size(); i += 3)
    v.viewpoints.emplace_back(coordinates[i], coordinates[i + 1], coordinates[i + 2]);
  v.min_range_m = config.get_double("visibility.min_range_m", v.min_range_m, 0.0, 1e3);
  v.max_range_m = config.get_double("visibility.max_range_m", v.max_range_m, 1e-3, 1e4);
  v.max_incidence_deg = config.get_double("visibility.max_incidence_deg", v.max_incidence_deg, 1.0, 90.0);
  v.max_abs_elevation_deg = config.get_double("visibility.max_abs_elevation_deg", v.max_abs_elevation_deg, 1.0, 90.0);
  options.colouring.map = parse_colour_map(config.get_string("colour.map", "viridis", {"viridis", "turbo"}));
  const std::vector<double> range =
      config.get_doubles("colour.range_m", {options.colouring.min_m, options.colouring.max_m}, 2);
  options.colouring.min_m = range[0];
  options.colouring.max_m = range[1];
  options.histogram_max_m = config.get_double("histogram.max_m", options.histogram_max_m, 0.0, 1e3);
  options.histogram_bins = config.get_int("histogram.bins", options.histogram_bins, 1, 100000);
  options.threads = config.get_int("threads", options.threads, 0, 1024);
  m.check(config.origin());
  return options;
}

CloudEvalReport evaluate_cloud_files(const std::filesystem::path& mesh_path, const std::filesystem::path& cloud_path,
                                     const CloudEvalOptions& options) {
  return evaluate_cloud_points(mesh_path, read_ply_point_cloud(cloud_path), cloud_path.string(), options);
}

CloudEvalReport evaluate_cloud_points(const std::filesystem::path& mesh_path, PointCloud cloud,
                                      const std::string& cloud_name, const CloudEvalOptions& options) {
  const auto start = Clock::now();
  CloudEvalReport report;
  report.mesh_path = mesh_path;
  report.cloud_path = cloud_name;
  report.options = options;
  if (options.histogram_bins <= 0) throw make_error("", "histogram.bins", "must be positive");
  if (options.threads < 0) throw make_error("", "threads", "must be >= 0 (0 = all cores)");
  for (const auto& trajectory : options.viewpoint_trajectories)
    report.options.metrics.completeness.visibility.viewpoints.push_back(mean_camera_centre(trajectory));
  report.options.metrics.check();

  if (!options.scene_from_cloud.isApprox(Rigid3d::Identity(), 0.0))
    for (auto& p : cloud.positions) p = options.scene_from_cloud * p;
  if (cloud.empty()) throw make_error(cloud_name, "element vertex", "the cloud has no points: nothing to evaluate");
  report.cloud_points = cloud.size();
  report.cloud_has_colours = cloud.has_colours();
  report.cloud_has_variances = cloud.has_variances();
  const TriangleMesh mesh = read_ply_mesh(mesh_path);

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    auto step = Clock::now();
    const MeshDistance mesh_distance(mesh, mesh_path.string());
    report.seconds_bvh = seconds_since(step);
    report.mesh_triangles = mesh.triangles.size();
    report.mesh_area_m2 = mesh_distance.surface_area();
    log_info(fmt::format("{}: {} triangles, BVH built in {:.2f} s", mesh_path.string(), mesh.triangles.size(),
                         report.seconds_bvh));

    step = Clock::now();
    std::vector<double> point_distances, sample_distances;
    report.metrics =
        evaluate_cloud(mesh_distance, cloud, cloud_name, report.options.metrics, &point_distances, &sample_distances);
    log_info(fmt::format("{}: {} points evaluated in {:.2f} s", cloud_name, cloud.size(), seconds_since(step)));

    double histogram_max = options.histogram_max_m;
    if (!(histogram_max > 0)) {
      histogram_max = 0.0;
      for (double t : report.options.metrics.thresholds_m) histogram_max = std::max(histogram_max, 2.0 * t);
    }
    report.accuracy_histogram_m = make_histogram(point_distances, histogram_max, options.histogram_bins);
    if (report.metrics.has_completeness)
      report.completeness_histogram_m = make_histogram(sample_distances, histogram_max, options.histogram_bins);
    if (!options.coloured_ply.empty()) {
      report.colour_legend = write_error_coloured_ply(options.coloured_ply, cloud, point_distances, options.colouring);
      log_info(fmt::format("wrote {} (colours: {})", options.coloured_ply.string(), report.colour_legend.describe()));
    }
  });
  // Most points far from the mesh: a reconstruction this bad is far likelier to be in another frame
  // than the mesh (or of another scene) than to be the method's real accuracy.
  if (!report.metrics.scores.empty()) {
    const ThresholdScore& widest = *std::max_element(
        report.metrics.scores.begin(), report.metrics.scores.end(),
        [](const ThresholdScore& a, const ThresholdScore& b) { return a.threshold_m < b.threshold_m; });
    if (widest.accuracy < options.min_share_near_mesh) {
      report.warnings.push_back(fmt::format(
          "{}: only {:.1f}% of the points lie within {:.0f} mm of the mesh (median distance {:.0f} mm): is the cloud "
          "in the mesh's frame? (tracked poses need --align-to-ground-truth; a wrong registration also does this)",
          cloud_name, 100.0 * widest.accuracy, 1e3 * widest.threshold_m, 1e3 * report.metrics.accuracy_m.median));
    }
  }
  report.seconds_total = seconds_since(start);
  return report;
}

std::string cloud_report_to_text(const CloudEvalReport& r) {
  const CloudMetrics& m = r.metrics;
  std::string out;
  out += fmt::format("cloud: {} ({} points{}{})\n", r.cloud_path.string(), r.cloud_points,
                     r.cloud_has_colours ? ", colour" : "", r.cloud_has_variances ? ", variance" : "");
  out += fmt::format("mesh:  {} ({} triangles, {:.2f} m^2)\n", r.mesh_path.string(), r.mesh_triangles, r.mesh_area_m2);
  out += fmt::format("accuracy, all {} points (exact point-to-triangle distance):\n  {}\n", m.accuracy_m.count,
                     stats_line(m.accuracy_m));
  if (m.outlier_cutoff_m > 0)
    out += fmt::format("accuracy within the cut-off {} mm ({} points beyond it, {}):\n  {}\n", mm(m.outlier_cutoff_m),
                       m.points_beyond_cutoff,
                       percent(double(m.points_beyond_cutoff) / double(std::max<std::size_t>(1, m.accuracy_m.count))),
                       stats_line(m.accuracy_within_cutoff_m));
  if (m.has_completeness) {
    const auto& viewpoints = r.options.metrics.completeness.visibility.viewpoints;
    out += fmt::format(
        "completeness: {} of {} surface samples ({:.2f} of {:.2f} m^2) {}; distance to the nearest point:\n  {}\n",
        m.visible_samples, m.surface_samples, m.visible_area_m2, m.sampled_area_m2,
        viewpoints.empty() ? std::string("(whole surface, no viewpoints given)")
                           : fmt::format("visible from {} viewpoint(s)", viewpoints.size()),
        stats_line(m.completeness_m));
  }
  out += "threshold   accuracy   completeness   F-score\n";
  for (const ThresholdScore& s : m.scores)
    out += fmt::format("{:>6.1f} mm   {:>8}   {:>12}   {:>7}\n", 1e3 * s.threshold_m, percent(s.accuracy),
                       percent(s.completeness), percent(s.f_score));
  if (!r.options.coloured_ply.empty())
    out += fmt::format("error-coloured cloud: {} ({})\n", r.options.coloured_ply.string(), r.colour_legend.describe());
  out += fmt::format("time: BVH {:.2f} s, accuracy {:.2f} s, completeness {:.2f} s, total {:.2f} s\n", r.seconds_bvh,
                     m.seconds_accuracy, m.seconds_completeness, r.seconds_total);
  for (const std::string& warning : r.warnings) out += "warning: " + warning + "\n";
  return out;
}

std::string cloud_report_to_json(const CloudEvalReport& r) {
  const CloudMetrics& m = r.metrics;
  const CloudMetricsOptions& o = r.options.metrics;
  nlohmann::json viewpoints = nlohmann::json::array();
  for (const auto& p : o.completeness.visibility.viewpoints) viewpoints.push_back({p.x(), p.y(), p.z()});
  std::vector<std::string> trajectories;
  for (const auto& t : r.options.viewpoint_trajectories) trajectories.push_back(t.string());

  nlohmann::json j;
  j["kind"] = "cloud_evaluation";
  j["warnings"] = r.warnings;
  j["panoscan_version"] = project_version();
  j["source_revision"] = source_revision();
  j["inputs"] = {{"mesh", r.mesh_path.string()},
                 {"mesh_triangles", r.mesh_triangles},
                 {"mesh_area_m2", r.mesh_area_m2},
                 {"cloud", r.cloud_path.string()},
                 {"cloud_points", r.cloud_points},
                 {"cloud_has_colours", r.cloud_has_colours},
                 {"cloud_has_variances", r.cloud_has_variances},
                 {"scene_from_cloud", pose_to_json(r.options.scene_from_cloud)}};
  j["settings"] = {{"distance", "exact point-to-triangle distance (Embree BVH proposes, double precision decides)"},
                   {"percentiles", "linear interpolation between order statistics (numpy default)"},
                   {"thresholds_m", o.thresholds_m},
                   {"outlier_cutoff_m", o.outlier_cutoff_m},
                   {"completeness",
                    {{"enabled", o.completeness.enabled},
                     {"samples_per_m2", o.completeness.samples_per_m2},
                     {"max_samples", o.completeness.max_samples},
                     {"seed", o.completeness.seed},
                     {"triangle_mask", !o.completeness.triangle_mask.empty()},
                     {"visibility",
                      {{"viewpoints", viewpoints},
                       {"viewpoint_trajectories", trajectories},
                       {"min_range_m", o.completeness.visibility.min_range_m},
                       {"max_range_m", o.completeness.visibility.max_range_m},
                       {"max_incidence_deg", o.completeness.visibility.max_incidence_deg},
                       {"max_abs_elevation_deg", o.completeness.visibility.max_abs_elevation_deg},
                       {"end_margin_m", o.completeness.visibility.end_margin_m}}}}},
                   {"threads", r.options.threads}};
  j["accuracy"] = stats_json(m.accuracy_m);
  j["accuracy_within_cutoff"] = m.outlier_cutoff_m > 0
                                    ? nlohmann::json{{"cutoff_m", m.outlier_cutoff_m},
                                                     {"points_beyond_cutoff", m.points_beyond_cutoff},
                                                     {"stats", stats_json(m.accuracy_within_cutoff_m)}}
                                    : nlohmann::json(nullptr);
  j["completeness"] = m.has_completeness ? nlohmann::json{{"surface_samples", m.surface_samples},
                                                          {"visible_samples", m.visible_samples},
                                                          {"sampled_area_m2", m.sampled_area_m2},
                                                          {"visible_area_m2", m.visible_area_m2},
                                                          {"stats", stats_json(m.completeness_m)}}
                                         : nlohmann::json(nullptr);
  nlohmann::json scores = nlohmann::json::array();
  for (const auto& s : m.scores)
    scores.push_back({{"threshold_m", s.threshold_m},
                      {"accuracy", s.accuracy},
                      {"completeness", s.completeness},
                      {"f_score", s.f_score}});
  j["scores"] = scores;
  j["histograms"] = {
      {"accuracy", histogram_json(r.accuracy_histogram_m)},
      {"completeness", m.has_completeness ? histogram_json(r.completeness_histogram_m) : nlohmann::json(nullptr)}};
  j["coloured_ply"] = r.options.coloured_ply.empty()
                          ? nlohmann::json(nullptr)
                          : nlohmann::json{{"path", r.options.coloured_ply.string()},
                                           {"colour_map", to_string(r.colour_legend.map)},
                                           {"range_m", {r.colour_legend.min, r.colour_legend.max}}};
  j["timing_s"] = {{"bvh", r.seconds_bvh},
                   {"accuracy", m.seconds_accuracy},
                   {"completeness", m.seconds_completeness},
                   {"total", r.seconds_total}};
  return j.dump(2) + "\n";
}

}  // namespace panoscan::eval
