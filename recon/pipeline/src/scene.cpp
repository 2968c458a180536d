#include "panoscan/recon/scene.h"

#include <chrono>

#include <fmt/format.h>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"

namespace panoscan {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

void register_scene_panoramas(const std::vector<Panorama>& panoramas, const std::vector<std::string>& names,
                              const SceneOptions& options, SceneResult& result) {
  const int n = int(panoramas.size());
  if (n == 0 || names.size() != panoramas.size()) throw make_error("", "scene", "needs one name per panorama");
  // Stage 2: registrations. The edge (source k -> target j) measures j_from_k between the
  // panorama frames.
  auto start = std::chrono::steady_clock::now();
  for (int target = 0; target < n; ++target)
    for (int source = target + 1; source < n; ++source) {
      const bool consecutive = source == target + 1;
      if (!consecutive && !options.register_all_pairs) continue;
      const std::string pair = names[source] + " -> " + names[target];
      try {
        log_info(fmt::format("registering {}", pair));
        PairEdge edge{source, target,
                      register_panorama_pair(panoramas[source], panoramas[target], options.registration,
                                             nullptr, names[source], names[target])};
        result.edges.push_back(std::move(edge));
      } catch (const Error& e) {
        if (consecutive) throw;
        result.skipped_pairs.push_back(std::string(e.what()));
        log_warn(fmt::format("skipped: {}", e.what()));
      }
    }

  // Poses: chain the consecutive edges from panorama 0 (placed at its own stored pose), then
  // refine with the pose graph when there are more edges than a chain.
  result.world_from_panorama.assign(n, Rigid3d::Identity());
  result.world_from_panorama[0] = panoramas[0].world_from_pano;
  for (int k = 1; k < n; ++k)
    for (const PairEdge& e : result.edges)
      if (e.source == k && e.target == k - 1)
        result.world_from_panorama[k] = result.world_from_panorama[k - 1] * e.registration.target_from_source;
  // A non-consecutive registration that contradicts the chain (a symmetric room can fool both the
  // features and the geometry, e.g. a 180-degree turn between diagonal positions) is dropped before
  // the pose graph, which would otherwise spread its error over every pose.
  std::vector<PairEdge> kept;
  for (PairEdge& e : result.edges) {
    const bool consecutive = e.source == e.target + 1;
    const EdgeDiscrepancy d = worst_edge_discrepancy(
        result.world_from_panorama, {{e.source, e.target, e.registration.target_from_source}});
    if (!consecutive && (d.rotation_deg > options.max_loop_rotation_deg || d.translation_m > options.max_loop_translation_m)) {
      result.skipped_pairs.push_back(fmt::format("{} -> {}: contradicts the chained registrations by {:.2f} deg, {:.0f} mm",
                                                 names[e.source], names[e.target], d.rotation_deg, d.translation_m * 1e3));
      log_warn(fmt::format("skipped: {}", result.skipped_pairs.back()));
      continue;
    }
    kept.push_back(std::move(e));
  }
  result.edges = std::move(kept);
  std::vector<PoseGraphEdge> graph_edges;
  for (const PairEdge& e : result.edges) graph_edges.push_back({e.source, e.target, e.registration.target_from_source});
  result.inconsistency_chained = worst_edge_discrepancy(result.world_from_panorama, graph_edges);
  if (int(result.edges.size()) > n - 1) {
    result.world_from_panorama = optimize_pose_graph(result.world_from_panorama, graph_edges, options.pose_graph).world_from_node;
    result.pose_graph_used = true;
  }
  result.inconsistency_final = worst_edge_discrepancy(result.world_from_panorama, graph_edges);
  result.seconds_registration = seconds_since(start);
}

SceneResult reconstruct_scene(const std::vector<SceneScan>& scans, const SceneOptions& options) {
  if (scans.empty()) throw make_error("", "scene", "no scans");
  SceneResult result;
  const int n = int(scans.size());

  // Stage 1 per scanning position.
  for (const SceneScan& input : scans) {
    auto start = std::chrono::steady_clock::now();
    RigTrajectory trajectory;
    if (input.trajectory) {
      trajectory = *input.trajectory;
      check_rig_trajectory(trajectory, input.scan, input.name);
    } else {
      log_info(fmt::format("{}: tracking", input.name));
      trajectory = track_scan(input.scan, options.tracking).trajectory;
    }
    result.seconds_tracking += seconds_since(start);
    start = std::chrono::steady_clock::now();
    log_info(fmt::format("{}: panorama ({})", input.name, to_string(options.panorama.fusion.method)));
    result.panoramas.push_back(build_panorama(input.scan, trajectory, options.panorama).panorama);
    result.seconds_panorama += seconds_since(start);
    result.trajectories.push_back(std::move(trajectory));
  }

  std::vector<std::string> names;
  for (const SceneScan& input : scans) names.push_back(input.name);
  register_scene_panoramas(result.panoramas, names, options, result);

  // Integration.
  const auto start = std::chrono::steady_clock::now();
  std::vector<PanoramaPoints> points;
  for (int k = 0; k < n; ++k)
    points.push_back(panorama_integration_points(result.panoramas[k], result.world_from_panorama[k], options.registration.cloud));
  result.integration = integrate_panoramas(points, options.integration);
  result.seconds_integration = seconds_since(start);
  return result;
}

SceneOptions scene_options_from_config(Config& config) {
  SceneOptions options;
  options.tracking = tracking_options_from_config(config);
  options.panorama = panorama_options_from_config(config);
  options.registration = pair_registration_options_from_config(config);
  options.register_all_pairs = config.get_bool("registration.all_pairs", options.register_all_pairs);
  options.integration = integration_options_from_config(config);
  return options;
}

}  // namespace panoscan
