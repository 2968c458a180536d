// `panoscan eval cloud`: a reconstructed cloud file against a ground-truth mesh file, with the
// report as text, as JSON, and an optional error-coloured PLY. The CLI only fills the options,
// calls evaluate_cloud_files() and prints / writes the results.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/eval/cloud_metrics.h"
#include "panoscan/eval/coloured_cloud.h"
#include "panoscan/eval/error_stats.h"

namespace panoscan {
class Config;
}

namespace panoscan::eval {

struct CloudEvalOptions {
  CloudMetricsOptions metrics;
  // Warn when fewer than this share of the points lie within the largest threshold of the mesh.
  double min_share_near_mesh = 0.5;
  // Each TUM trajectory (e.g. a scan's groundtruth/camK.txt) adds one viewpoint for the
  // visibility test of completeness: the mean of its camera centres (an in-place scan's camera
  // centres lie within ~10 cm of it).
  std::vector<std::filesystem::path> viewpoint_trajectories;
  // Applied to the cloud before anything is measured: the scene frame from the cloud's frame (an
  // outside system's output lives in its first camera's frame; `export prestitched` writes that
  // camera's pose as scene_from_sequence.txt).
  Rigid3d scene_from_cloud = Rigid3d::Identity();
  std::filesystem::path coloured_ply;  // empty: do not write
  ErrorColouring colouring;
  double histogram_max_m = 0.0;  // <= 0: twice the largest threshold
  int histogram_bins = 100;
  int threads = 0;  // 0 = all cores
};

// Keys (all optional; defaults as in the structs):
//   thresholds_m: [0.01, 0.02, 0.05]      outlier_cutoff_m: 0 (off)     min_share_near_mesh: 0.5
//   completeness.enabled: true            completeness.samples_per_m2: 4000
//   completeness.max_samples: 2000000     completeness.seed: 1
//   visibility.viewpoints: [x, y, z, x, y, z, ...]   (metres, scene frame)
//   visibility.min_range_m: 0   visibility.max_range_m: 8   visibility.max_incidence_deg: 82
//   visibility.max_abs_elevation_deg: 90
//   colour.map: viridis | turbo           colour.range_m: [0, 0.05] (max <= min: 99th percentile)
//   histogram.max_m: 0 (auto)             histogram.bins: 100
//   threads: 0
CloudEvalOptions cloud_eval_options_from_config(Config& config);

struct CloudEvalReport {
  std::filesystem::path mesh_path, cloud_path;
  std::size_t mesh_triangles = 0;
  double mesh_area_m2 = 0.0;
  std::size_t cloud_points = 0;
  bool cloud_has_colours = false, cloud_has_variances = false;
  CloudEvalOptions options;  // as used (viewpoints resolved into options.metrics)
  CloudMetrics metrics;
  Histogram accuracy_histogram_m;                 // reconstructed points -> mesh
  Histogram completeness_histogram_m;             // visible samples -> cloud (empty without completeness)
  ColourLegend colour_legend;                     // when a coloured PLY was written
  double seconds_bvh = 0.0, seconds_total = 0.0;  // the rest is in metrics
  // What the figures suggest is wrong with the input (printed, in the JSON, and logged): today one,
  // when most points lie farther from the mesh than the largest threshold, which a cloud in another
  // frame than the mesh's (tracked poses without --align-to-ground-truth, a wrong registration) gives.
  std::vector<std::string> warnings;
};

// Reads the mesh (read_ply_mesh) and the cloud (read_ply_point_cloud; a mesh PLY gives its
// vertices), evaluates, writes the coloured PLY if asked. Throws Error naming the file for bad
// input: missing/corrupt files, a mesh without triangles, an empty cloud, NaN coordinates.
CloudEvalReport evaluate_cloud_files(const std::filesystem::path& mesh_path, const std::filesystem::path& cloud_path,
                                     const CloudEvalOptions& options = {});
// The same for a cloud in memory (the Python module's arrays); `cloud_name` names it in errors and
// in the report.
CloudEvalReport evaluate_cloud_points(const std::filesystem::path& mesh_path, PointCloud cloud,
                                      const std::string& cloud_name, const CloudEvalOptions& options = {});

// Human-readable summary in millimetres (what the CLI prints).
std::string cloud_report_to_text(const CloudEvalReport& report);
// Every figure, the settings and the project version, as a JSON document (figures in metres, as
// "_m" keys, and the headline ones in millimetres as "_mm").
std::string cloud_report_to_json(const CloudEvalReport& report);

}  // namespace panoscan::eval
