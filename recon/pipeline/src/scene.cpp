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

  // Stage 2: registrations. The edge (source k -> target j) measures j_from_k between the
  // panorama frames.
  auto start = std::chrono::steady_clock::now();
  for (int target = 0; target < n; ++target)
    for (int source = target + 1; source < n; ++source) {
      const bool consecutive = source == target + 1;
      if (!consecutive && !options.register_all_pairs) continue;
      const std::string pair = scans[source].name + " -> " + scans[target].name;
      try {
        log_info(fmt::format("registering {}", pair));
        PairEdge edge{source, target,
                      register_panorama_pair(result.panoramas[source], result.panoramas[target], options.registration,
                                             nullptr, scans[source].name, scans[target].name)};
        result.edges.push_back(std::move(edge));
      } catch (const Error& e) {
        if (consecutive) throw;
        result.skipped_pairs.push_back(std::string(e.what()));
        log_warn(fmt::format("skipped: {}", e.what()));
      }
    }

  // Poses: chain the consecutive edges from panorama 0 (placed at its own tracked pose), then
  // refine with the pose graph when there are more edges than a chain.
  result.world_from_panorama.assign(n, Rigid3d::Identity());
  result.world_from_panorama[0] = result.panoramas[0].world_from_pano;
  for (int k = 1; k < n; ++k)
    for (const PairEdge& e : result.edges)
      if (e.source == k && e.target == k - 1)
        result.world_from_panorama[k] = result.world_from_panorama[k - 1] * e.registration.target_from_source;
  if (int(result.edges.size()) > n - 1) {
    std::vector<PoseGraphEdge> graph_edges;
    for (const PairEdge& e : result.edges)
      graph_edges.push_back({e.source, e.target, e.registration.target_from_source});
    result.world_from_panorama = optimize_pose_graph(result.world_from_panorama, graph_edges, options.pose_graph).world_from_node;
    result.pose_graph_used = true;
  }
  result.seconds_registration = seconds_since(start);

  // Integration.
  start = std::chrono::steady_clock::now();
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
  IcpOptions& icp = options.registration.icp;
  icp.method = icp_method_from_string(config.get_string(
      "registration.method", to_string(icp.method),
      {"p2point", "p2plane", "p2plane-curv", "gicp", "anisotropic", "gicp-def", "gicp-ours"}));
  icp.max_correspondence_m = config.get_double("registration.max_correspondence_m", icp.max_correspondence_m, 1e-3, 10.0);
  icp.max_iterations = config.get_int("registration.max_iterations", icp.max_iterations, 1, 1000);
  icp.threads = config.get_int("threads", 0, 0, 1024);
  PanoramaCloudOptions& cloud = options.registration.cloud;
  // "Def." (Table 4) means the general noise model in place of the measured variance.
  const std::string covariance = config.get_string(
      "registration.covariance", icp.method == IcpMethod::kGicpNoiseModel ? "handa-model" : "measured",
      {"measured", "handa-model"});
  cloud.covariance = covariance == "measured" ? DepthCovarianceModel::kMeasured : DepthCovarianceModel::kHandaModel;
  cloud.pixel_stride = config.get_int("registration.pixel_stride", cloud.pixel_stride, 1, 64);
  cloud.min_observations = config.get_int("registration.min_observations", cloud.min_observations, 1, 1000);
  cloud.max_sigma_m = config.get_double("registration.max_sigma_m", cloud.max_sigma_m, 1e-4, 10.0);
  cloud.surface.threads = icp.threads;
  options.registration.features.seed = config.get_u64("seed", 1);
  options.register_all_pairs = config.get_bool("registration.all_pairs", options.register_all_pairs);
  options.integration.method = merge_method_from_string(
      config.get_string("integration.method", to_string(options.integration.method), {"map", "average", "align"}));
  options.integration.weighting =
      config.get_string("integration.weighting", "information", {"information", "paper-inverse-sqrt"}) == "information"
          ? MapWeighting::kInformation
          : MapWeighting::kPaperInverseSqrt;
  options.integration.threads = icp.threads;
  return options;
}

}  // namespace panoscan
