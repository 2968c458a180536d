// Table 5 (paper §6.3): integration of registered panoramas. Each pair (and, at the full size or
// with --only SO, the whole office "SO": four positions, every pair registered, the pose graph) is
// registered with GICP (Ours) from the ORB guess, then merged three ways: all pixels placed by
// their poses ("Align only"), mutual-best groups averaged ("Align + average") or merged by the MAP
// closed form of Eq. 11 ("Align + MAP"). RMSE of the cloud against the mesh, every point.
//
// Panoramas come from ground-truth poses, as in Table 4 (stage 2 alone); the first panorama of a
// column stays at its true pose, so that the cloud is in the scene frame.
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "drivers.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/scene.h"
#include "stage2_common.h"

namespace panoscan::tables {

namespace {

const std::vector<std::pair<MergeMethod, std::string>>& rows() {
  static const std::vector<std::pair<MergeMethod, std::string>> r = {{MergeMethod::kAlignOnly, "Align only"},
                                                                     {MergeMethod::kAverage, "Align + average"},
                                                                     {MergeMethod::kMap, "Align + MAP"}};
  return r;
}

struct Tables {
  eval::ResultTable rmse, mean, points;
};

void integrate_column(const std::string& column, const std::vector<Panorama>& panoramas,
                      const std::vector<Rigid3d>& world_from_panorama, const eval::MeshDistance& mesh,
                      const TablesOptions& options, Tables& tables, TableRun& run) {
  const PanoramaCloudOptions cloud = stage2::integration_cloud_options(options);
  std::vector<PanoramaPoints> points;
  for (std::size_t k = 0; k < panoramas.size(); ++k)
    points.push_back(panorama_integration_points(panoramas[k], world_from_panorama[k], cloud));
  for (const auto& [method, name] : rows()) {
    IntegrationOptions integration;
    integration.method = method;
    integration.threads = options.threads;
    const IntegrationResult result = integrate_panoramas(points, integration);
    const stage2::DistanceStats stats = stage2::distance_stats(mesh.distances(result.cloud.positions, column));
    tables.rmse.set(name, column, stats.rmse_mm);
    tables.mean.set(name, column, stats.mean_mm);
    tables.points.set(name, column, double(result.cloud.size()));
    if (method == MergeMethod::kMap)
      run.notes.push_back(fmt::format("{}: {} pixels, {} mutual pairs, {} groups of {} pixels", column,
                                      result.input_points, result.mutual_pairs, result.groups, result.grouped_points));
  }
  // Ablation (not in the paper): MAP with every pixel's sigma_z replaced by its panorama's median.
  PanoramaCloudOptions constant = cloud;
  constant.covariance = DepthCovarianceModel::kConstant;
  for (std::size_t k = 0; k < panoramas.size(); ++k) {
    const PanoramaPoints constant_points = panorama_integration_points(panoramas[k], world_from_panorama[k], constant);
    points[k].covariances = constant_points.covariances;  // same pixels, other measurement covariance
  }
  IntegrationOptions integration;
  integration.threads = options.threads;
  const IntegrationResult result = integrate_panoramas(points, integration);
  const stage2::DistanceStats stats = stage2::distance_stats(mesh.distances(result.cloud.positions, column));
  const std::string name = "Align + MAP (constant sigma_z; ablation)";
  tables.rmse.set(name, column, stats.rmse_mm);
  tables.mean.set(name, column, stats.mean_mm);
  tables.points.set(name, column, double(result.cloud.size()));
}

// The office's four positions: every pair registered, the pose graph, then integration; with the
// pose-graph figures (worst pairwise inconsistency and worst pose error against the truth, chained
// and after the graph).
// The office's four positions (built-in rooms only): at the full size, or when --only names SO.
bool has_office_column(const TablesOptions& options) {
  const bool builtin = std::find(options.scenes.begin(), options.scenes.end(), "builtin") != options.scenes.end();
  return builtin && (options.size == "full" ||
                     std::find(options.only.begin(), options.only.end(), "SO") != options.only.end());
}

std::vector<Column> table5_columns(const TablesOptions& options) {
  std::vector<Column> columns = pair_columns(options);
  if (has_office_column(options)) columns.push_back({"SO", {"SO-1", "SO-2", "SO-3", "SO-4"}});
  return columns;
}

void office_column(const TablesOptions& options, const PairRegistrationOptions& registration, Tables& tables,
                   eval::ResultTable& graph, TableRun& run) {
  const std::vector<std::string> names = {"SO-1", "SO-2", "SO-3", "SO-4"};
  std::vector<Panorama> panoramas;
  for (const std::string& name : names) panoramas.push_back(stage2::ground_truth_panorama(name, options));
  SceneOptions scene;
  scene.registration = registration;
  scene.register_all_pairs = true;
  SceneResult result;
  // Positions in a loop (1, 3, 2, 4 around the office's two rows) so that consecutive ones are
  // neighbours; the other pairs close it.
  const std::vector<int> order = {0, 2, 1, 3};
  std::vector<Panorama> ordered;
  std::vector<std::string> ordered_names;
  for (int k : order) {
    ordered.push_back(panoramas[k]);
    ordered_names.push_back(names[k]);
  }
  register_scene_panoramas(ordered, ordered_names, scene, result);
  const std::vector<Rigid3d>& chained = result.placement.world_from_panorama_chained;  // before the graph
  auto worst_pose_error = [&](const std::vector<Rigid3d>& poses) {
    EdgeDiscrepancy worst;
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const Rigid3d& truth = ordered[k].world_from_pano;
      worst.rotation_deg =
          std::max(worst.rotation_deg, rad2deg(rotation_angle(truth.linear().transpose() * poses[k].linear())));
      worst.translation_m = std::max(worst.translation_m, (poses[k].translation() - truth.translation()).norm());
    }
    return worst;
  };
  const EdgeDiscrepancy inconsistency_chained = result.inconsistency_chained;
  const EdgeDiscrepancy inconsistency_final = result.inconsistency_final;
  const EdgeDiscrepancy error_chained = worst_pose_error(chained),
                        error_final = worst_pose_error(result.world_from_panorama);
  const std::string graph_row =
      result.pose_graph_used ? "Pose graph" : "Pose graph (not used: no redundant registration)";
  graph.set("Chained registrations", "inconsistency (mm)", inconsistency_chained.translation_m * 1e3);
  graph.set("Chained registrations", "inconsistency (deg)", inconsistency_chained.rotation_deg);
  graph.set("Chained registrations", "pose error (mm)", error_chained.translation_m * 1e3);
  graph.set("Chained registrations", "pose error (deg)", error_chained.rotation_deg);
  graph.set(graph_row, "inconsistency (mm)", inconsistency_final.translation_m * 1e3);
  graph.set(graph_row, "inconsistency (deg)", inconsistency_final.rotation_deg);
  graph.set(graph_row, "pose error (mm)", error_final.translation_m * 1e3);
  graph.set(graph_row, "pose error (deg)", error_final.rotation_deg);
  run.notes.push_back(fmt::format("SO: {} registrations ({} skipped{}), pose graph {}", result.edges.size(),
                                  result.skipped_pairs.size(),
                                  result.skipped_pairs.empty() ? "" : ": " + result.skipped_pairs.front(),
                                  result.pose_graph_used ? "used" : "not used"));
  const auto mesh = stage2::scene_mesh("SO-1", options);
  integrate_column("SO", ordered, result.world_from_panorama, *mesh, options, tables, run);
}

TableRun run_table5(const TablesOptions& options) {
  const SizePreset preset = size_preset(options.size);
  const PairRegistrationOptions registration = stage2::registration_options(options);
  TableRun run;
  Tables tables;
  tables.rmse.title = "Table 5: integration, RMSE of the merged cloud against the mesh";
  tables.rmse.decimals = 3;
  tables.mean.title = "Table 5 (mean distance to the mesh)";
  tables.mean.decimals = 3;
  tables.points.title = "Table 5 (points in the merged cloud)";
  tables.points.unit = "points";
  tables.points.decimals = 0;
  tables.points.lower_is_better = false;
  eval::ResultTable graph;
  graph.title = "Table 5 (pose graph on SO, four positions: worst over edges / panoramas)";
  graph.unit = "mm, deg";
  graph.decimals = 3;

  const std::vector<std::string> pairs = pair_labels(options);
  for (const std::string& pair : pairs) {
    const auto [source_label, target_label] = pair_scans(pair);
    const Panorama source = stage2::ground_truth_panorama(source_label, options);
    const Panorama target = stage2::ground_truth_panorama(target_label, options);
    log_info(fmt::format("table5: {} ({} -> {})", pair, source_label, target_label));
    PairRegistration registered;
    try {
      registered = register_panorama_pair(source, target, registration, nullptr, source_label, target_label);
    } catch (const Error& e) {
      run.notes.push_back(fmt::format("{}: registration failed: {}", pair, e.what()));
      run.failures.push_back({pair, "registration failed", e.what()});
      continue;
    }
    const Rigid3d truth = target.world_from_pano.inverse() * source.world_from_pano;
    run.notes.push_back(
        fmt::format("{}: GICP (Ours) registration error {:.4f} deg, {:.2f} mm", pair,
                    rad2deg(rotation_angle(truth.linear().transpose() * registered.target_from_source.linear())),
                    (registered.target_from_source.translation() - truth.translation()).norm() * 1e3));
    const auto mesh = stage2::scene_mesh(source_label, options);
    integrate_column(pair, {target, source},
                     {target.world_from_pano, target.world_from_pano * registered.target_from_source}, *mesh, options,
                     tables, run);
  }
  const bool office = has_office_column(options);
  if (office) office_column(options, registration, tables, graph, run);
  // A pair whose registration refused is a result (a note, no cells: the merged record counts the
  // seeds that have a cell); only a selection with nothing to run is an error.
  if (pairs.empty() && !office) throw make_error("table5", "--only", "names no pair (e.g. SO-13) and not SO");

  run.notes.push_back(fmt::format(
      "Panoramas from ground-truth poses (TSA, H = {}), registered with GICP (Ours) from the ORB guess (every {}-th "
      "pixel row and column); integration over every usable pixel (sigma_z <= {} m, >= {} observations), mutual best "
      "pairs within {} m, MAP with information weights (Eq. 10's minimiser; the printed inverse-sqrt form is "
      "integration.weighting=paper-inverse-sqrt). RMSE over every point (no cut-off).",
      preset.panorama_height, registration.cloud.pixel_stride, registration.cloud.max_sigma_m,
      registration.cloud.min_observations, IntegrationOptions{}.max_correspondence_m));
  run.tables = {tables.rmse, tables.mean, tables.points};
  if (office) run.tables.push_back(graph);
  nlohmann::json settings = {{"poses", "ground-truth"},
                             {"registration", "gicp-ours"},
                             {"registration_pixel_stride", registration.cloud.pixel_stride},
                             {"office_column", office},
                             {"pairs", pairs}};
  run.settings_json = settings.dump();
  run.claims = {
      {"Table 5:", "Align + MAP", "Align only", "MAP integration beats the registered clouds side by side"},
      {"Table 5:", "Align + MAP", "Align + average", "MAP integration beats averaging matched points"},
      {"Table 5:", "Align + MAP", "Align + MAP (constant sigma_z; ablation)",
       "the per-pixel variance in MAP beats one constant sigma_z (ablation)"},
  };
  return run;
}

}  // namespace

TableDriver table5_driver() {
  return {"table5", "integration (paper Table 5): align only, + average, + MAP; pose graph on the office (SO)",
          run_table5, table5_columns};
}

}  // namespace panoscan::tables
