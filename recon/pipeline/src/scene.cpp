#include "panoscan/recon/scene.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/timer.h"

namespace panoscan {

void register_scene_panoramas(const std::vector<Panorama>& panoramas, const std::vector<std::string>& names,
                              const SceneOptions& options, SceneResult& result) {
  const int n = int(panoramas.size());
  if (n == 0 || names.size() != panoramas.size()) throw make_error("", "scene", "needs one name per panorama");
  // Stage 2: registrations. The edge (source k -> target j) measures j_from_k between the
  // panorama frames.
  auto start = steady_now();
  // Each panorama's cloud (with surfaces) and ORB features once, not once per pair it is in.
  std::vector<PreparedPanorama> prepared;
  struct PairFailure {
    int source, target;
    std::string reason;
  };
  std::vector<PairFailure> failures;
  for (int k = 0; k < n; ++k) prepared.push_back(prepare_panorama_for_registration(panoramas[k], options.registration, names[k]));
  for (int target = 0; target < n; ++target)
    for (int source = target + 1; source < n; ++source) {
      const bool consecutive = source == target + 1;
      if (!consecutive && !options.register_all_pairs) continue;
      const std::string pair = names[source] + " -> " + names[target];
      try {
        log_info(fmt::format("registering {}", pair));
        PairEdge edge{source, target,
                      register_panorama_pair(prepared[source], prepared[target], options.registration, nullptr)};
        result.edges.push_back(std::move(edge));
      } catch (const Error& e) {
        // Without the other pairs, a consecutive pair is the only link of its scan.
        if (consecutive && !options.register_all_pairs) throw;
        result.skipped_pairs.push_back(std::string(e.what()));
        failures.push_back({source, target, e.what()});
        log_warn(fmt::format("skipped: {}", e.what()));
      }
    }
  std::vector<PoseGraphEdge> graph_edges;
  for (const PairEdge& e : result.edges) graph_edges.push_back({e.source, e.target, e.registration.target_from_source});
  // A scan the registrations that succeeded do not link to the first cannot be placed: say why its
  // own pairs failed (its pair with the scan before it first), not only that it is unlinked.
  if (const std::vector<int> unlinked = unlinked_panoramas(n, graph_edges); !unlinked.empty()) {
    const int k = unlinked.front();
    std::string reasons;
    for (int pass = 0; pass < 2; ++pass)
      for (const PairFailure& f : failures) {
        const bool with_previous = f.source == k && f.target == k - 1;
        if ((f.source == k || f.target == k) && with_previous == (pass == 0))
          reasons += (reasons.empty() ? "" : "; ") + f.reason;
      }
    throw make_error(names[k], "registrations",
                     "no registration that succeeded links it to " + names[0] + " (" + reasons + ")");
  }

  // Poses: the one placement rule of recon scene and recon integrate (placement.h).
  const auto placement_start = steady_now();
  result.placement = place_panoramas(names, panoramas[0].world_from_pano, graph_edges, options.placement);
  result.seconds_pose_graph = seconds_since(placement_start);
  const Placement& placement = result.placement;
  result.registrations = graph_edges;
  std::vector<PairEdge> kept;
  for (std::size_t k = 0; k < result.edges.size(); ++k)
    if (placement.edge_kept[k]) kept.push_back(std::move(result.edges[k]));
  result.edges = std::move(kept);
  result.skipped_pairs.insert(result.skipped_pairs.end(), placement.dropped.begin(), placement.dropped.end());
  result.world_from_panorama = placement.world_from_panorama;
  result.pose_graph_used = placement.pose_graph_used;
  result.inconsistency_chained = placement.inconsistency_chained;
  result.inconsistency_final = placement.inconsistency_final;
  result.seconds_registration = seconds_since(start);
}

SceneResult reconstruct_scene(const std::vector<SceneScan>& scans, const SceneOptions& options) {
  if (scans.empty()) throw make_error("", "scene", "no scans");
  SceneResult result;
  const int n = int(scans.size());

  // Stage 1 per scanning position.
  for (const SceneScan& input : scans) {
    auto start = steady_now();
    RigTrajectory trajectory;
    if (input.trajectory) {
      trajectory = *input.trajectory;
      check_rig_trajectory(trajectory, input.scan, input.name);
    } else {
      log_info(fmt::format("{}: tracking", input.name));
      TrackingResult tracked = track_scan(input.scan, options.tracking);
      require_reliable_tracking(tracked, options.tracking, input.name);
      trajectory = std::move(tracked.trajectory);
    }
    result.seconds_tracking += seconds_since(start);
    start = steady_now();
    log_info(fmt::format("{}: panorama ({})", input.name, to_string(options.panorama.fusion.method)));
    result.panoramas.push_back(build_panorama(input.scan, trajectory, options.panorama).panorama);
    result.seconds_panorama += seconds_since(start);
    result.trajectories.push_back(std::move(trajectory));
  }

  std::vector<std::string> names;
  for (const SceneScan& input : scans) names.push_back(input.name);
  register_scene_panoramas(result.panoramas, names, options, result);

  // Integration.
  const auto start = steady_now();
  std::vector<PanoramaPoints> points;
  for (int k = 0; k < n; ++k)
    points.push_back(
        panorama_integration_points(result.panoramas[k], result.world_from_panorama[k], options.registration.cloud));
  result.integration = integrate_panoramas(points, options.integration);
  result.seconds_integration = seconds_since(start);
  return result;
}

nlohmann::json scene_registrations_to_json(const std::vector<std::string>& names, const SceneResult& result) {
  nlohmann::json j;
  j["format"] = "panoscan-scene-registrations";
  j["version"] = 1;
  j["kept"] = nlohmann::json::array();
  for (const PairEdge& e : result.edges) {
    const PairRegistration& r = e.registration;
    nlohmann::json pair = {{"source", names.at(std::size_t(e.source))},
                           {"target", names.at(std::size_t(e.target))},
                           {"target_from_source", pose_to_json(r.target_from_source)},
                           {"overlap", r.overlap},
                           {"orb",
                            {{"matches", r.guess.matches},
                             {"inliers", r.guess.inliers},
                             {"guided_matches", r.guess.guided_matches},
                             {"evidence", r.guess.evidence()}}},
                           {"consistent_matches", r.consistent_matches},
                           {"runner_up", runner_up_to_json(r)}};
    j["kept"].push_back(std::move(pair));
  }
  j["skipped"] = result.skipped_pairs;
  return j;
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
