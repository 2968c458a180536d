// `panoscan recon register` and `panoscan recon integrate`: stage 2 of the method (paper §5) on
// panorama folders written by `recon panorama` or `recon scene`; `recon register` also on point-cloud
// files (.ply / .pcd, recon/pipeline's cloud_registration.h). No algorithm lives here: reading,
// calling recon/pipeline's stage2.h and recon/integration, reporting.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "panoscan/core/atomic_output.h"
#include "panoscan/core/cloud_file.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/log.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/timer.h"
#include "panoscan/recon/cloud_registration.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/placement.h"
#include "panoscan/recon/stage2.h"

namespace fs = std::filesystem;

namespace panoscan::app {

namespace {

Config load_stage2_config(const std::string& file, const std::vector<std::string>& overrides, int threads) {
  Config config = file.empty() ? Config() : Config::load_file(file);
  for (const auto& o : overrides) config.apply_override(o);
  if (threads >= 0) config.set("threads", std::to_string(threads));
  return config;
}

// One `recon register` output as a pose-graph edge between two of `panoramas` (by absolute path; a
// folder moved since is found by name when that name is unique among them).
PoseGraphEdge read_registration_edge(const std::string& file, const std::vector<std::string>& panoramas) {
  const nlohmann::json j = read_json_file(file, "expected an output of recon register");
  for (const char* field : {"source", "target", "target_from_source"})
    if (!j.is_object() || !j.contains(field))
      throw make_error(file, field, "missing (expected an output of recon register)");
  if (!j["source"].is_string() || !j["target"].is_string())
    throw make_error(file, "source", "source and target must be panorama folder paths");
  auto index_of = [&](const std::string& path, const std::string& field) {
    const std::string wanted = fs::weakly_canonical(path).string();
    int found = -1, matches = 0;
    for (int k = 0; k < int(panoramas.size()); ++k) {
      const std::string candidate = fs::weakly_canonical(panoramas[k]).string();
      if (candidate == wanted) return k;
      if (fs::path(candidate).filename() == fs::path(wanted).filename()) found = k, ++matches;
    }
    if (matches == 1) return found;
    throw make_error(file, field, "'" + path + "' is not one of --panoramas");
  };
  PoseGraphEdge e;
  e.from = index_of(j["source"].get<std::string>(), "source");
  e.to = index_of(j["target"].get<std::string>(), "target");
  if (e.from == e.to) throw make_error(file, "target", "registers a panorama with itself");
  e.to_from_from = pose_from_json(j["target_from_source"], file, "target_from_source");
  return e;
}

std::string absolute_path(const std::string& path) { return fs::absolute(path).lexically_normal().string(); }

// What --source / --target name: a panorama folder or a point-cloud file (by what is there, then
// the extension). Both must be of one kind.
bool registers_clouds(const ReconRegisterArguments& a) {
  auto is_cloud = [](const std::string& path, const char* option) {
    std::error_code ec;
    if (fs::is_directory(path, ec)) return false;
    if (is_cloud_file_path(path)) return true;
    if (fs::exists(path, ec))
      throw make_error(path, option, "neither a panorama folder nor a point-cloud file (.ply, .pcd)");
    throw make_error(path, option, "not found (expected a panorama folder or a .ply / .pcd point-cloud file)");
  };
  const bool source = is_cloud(a.source, "--source"), target = is_cloud(a.target, "--target");
  if (source != target)
    throw make_error(source ? a.target : a.source, source ? "--target" : "--source",
                     std::string("is a ") + (source ? "panorama folder" : "point-cloud file") + " but " +
                         (source ? a.source : a.target) + " is a " + (source ? "point-cloud file" : "panorama folder") +
                         ": register two of a kind");
  return source;
}

// --matrix, or --out with its .json extension replaced by .txt.
std::string matrix_path(const ReconRegisterArguments& a) {
  if (!a.matrix.empty()) return a.matrix;
  fs::path path(a.out);
  if (path.extension() == ".json")
    path.replace_extension(".txt");
  else
    path += ".txt";
  return path.string();
}

// The ICP part of a registration's JSON, the same for panoramas and point clouds.
nlohmann::json icp_json(const IcpResult& icp, const IcpOptions& options) {
  return {{"iterations", icp.iterations},
          {"converged", icp.converged},
          {"correspondences", icp.correspondences},
          {"inlier_fraction", icp.inlier_fraction},
          {"fitness", icp.fitness},
          {"fitness_distance_m", options.fitness_distance_m},
          {"rmse_m", icp.rmse_m},
          {"coarse_levels", options.coarse_levels},
          // Wall-clock seconds of the ICP's phases (IcpResult::timings).
          {"seconds",
           {{"setup", icp.timings.setup_s},
            {"correspondences", icp.timings.correspondence_s},
            {"linearisation", icp.timings.linearise_s},
            {"solve", icp.timings.solve_s}}}};
}

void write_register_outputs(const ReconRegisterArguments& a, const std::string& matrix, const nlohmann::json& j,
                            const Rigid3d& target_from_source) {
  write_file_atomic(a.out, j.dump(2) + "\n");
  write_file_atomic(matrix, pose_matrix_text(target_from_source));
}

void run_recon_register_clouds(const ReconRegisterArguments& a, Config& config, const std::string& matrix) {
  if (a.voxel_m >= 0) config.set("registration.voxel_m", std::to_string(a.voxel_m));
  const CloudRegistrationOptions options = cloud_registration_options_from_config(config);
  config.check_all_used();
  std::optional<Rigid3d> initial;
  if (!a.initial.empty()) initial = read_pose_file(a.initial);
  const CloudFile source = read_cloud_file(a.source);
  const CloudFile target = read_cloud_file(a.target);

  const SteadyTime start = steady_now();
  const CloudPairRegistration r =
      register_cloud_files(source, target, initial ? *initial : Rigid3d::Identity(), options);
  const double seconds = seconds_since(start);

  auto describe = [&](const CloudFile& file, std::size_t used, bool covariance_used) {
    const Eigen::Vector3d viewpoint = cloud_file_viewpoint(file);
    return nlohmann::json{{"format", file.format},
                          {"points_in_file", file.declared_points},
                          {"dropped_nan_points", file.dropped_invalid},
                          {"registered_points", used},
                          {"uncertainty_field", file.uncertainty.empty() ? "none" : file.uncertainty},
                          {"covariance_used", covariance_used},
                          {"viewpoint", {viewpoint.x(), viewpoint.y(), viewpoint.z()}},
                          {"viewpoint_from", file.has_viewpoint ? "VIEWPOINT" : "origin (the file gives none)"}};
  };
  nlohmann::json j;
  j["kind"] = "point-clouds";
  j["source"] = absolute_path(a.source);
  j["target"] = absolute_path(a.target);
  j["method"] = to_string(options.icp.method);
  j["method_used"] = to_string(r.method_used);
  j["covariance"] = r.covariance_note;
  j["voxel_m"] = options.voxel_m;
  j["target_from_source"] = pose_to_json(r.target_from_source);
  j["matrix_file"] = absolute_path(matrix);
  j["initial"] = {{"kind", initial ? "given" : "identity"},
                  {"pose", pose_to_json(initial ? *initial : Rigid3d::Identity())}};
  j["clouds"] = {{"source", describe(source, r.source_points, r.source_covariance)},
                 {"target", describe(target, r.target_points, r.target_covariance)}};
  j["icp"] = icp_json(r.icp, options.icp);
  j["overlap"] = r.overlap;
  j["seconds"] = seconds;
  write_register_outputs(a, matrix, j, r.target_from_source);
  const Eigen::Vector3d t = r.target_from_source.translation();
  std::cout << fmt::format(
      "registered {} -> {} ({}{}): t = ({:.4f}, {:.4f}, {:.4f}) m, rotation {:.3f} deg; initial {}; {} and {} "
      "points, {} iterations, overlap {:.2f}, {:.1f} s; wrote {} and {}\n",
      a.source, a.target, to_string(r.method_used),
      r.method_used != options.icp.method ? std::string(", for ") + to_string(options.icp.method) + ": no covariances"
                                          : std::string(),
      t.x(), t.y(), t.z(), rad2deg(rotation_angle(r.target_from_source.linear())), initial ? "given" : "identity",
      r.source_points, r.target_points, r.icp.iterations, r.overlap, seconds, a.out, matrix);
}

}  // namespace

void run_recon_register(const ReconRegisterArguments& a) {
  if (a.out.empty()) throw make_error("--out", "", "an output JSON file is required");
  const std::string matrix = matrix_path(a);
  if (fs::absolute(matrix).lexically_normal() == fs::absolute(a.out).lexically_normal())
    throw make_error(matrix, "--matrix", "is the same file as --out");
  Config config = load_stage2_config(a.config_file, a.overrides, a.threads);
  if (!a.method.empty()) config.set("registration.method", a.method);
  for (const std::string& output : {a.out, matrix})
    if (fs::exists(output) && !a.overwrite)
      throw make_error(output, "", "already exists (use --overwrite to replace it)");
  if (registers_clouds(a)) {
    run_recon_register_clouds(a, config, matrix);
    return;
  }
  if (a.voxel_m >= 0) throw make_error("--voxel", "", "applies to point-cloud files only, not to panoramas");
  const PairRegistrationOptions options = pair_registration_options_from_config(config);
  config.check_all_used();
  std::optional<Rigid3d> initial;
  if (!a.initial.empty()) initial = read_pose_file(a.initial);
  const Panorama source = read_panorama(a.source);
  const Panorama target = read_panorama(a.target);

  const SteadyTime start = steady_now();
  const PairRegistration r =
      register_panorama_pair(source, target, options, initial ? &*initial : nullptr, a.source, a.target);
  const double seconds = seconds_since(start);

  nlohmann::json j;
  j["source"] = absolute_path(a.source);
  j["target"] = absolute_path(a.target);
  j["method"] = to_string(options.icp.method);
  j["covariance"] = to_string(options.cloud.covariance);
  j["target_from_source"] = pose_to_json(r.target_from_source);
  j["initial"] = {{"kind", initial ? "given" : "orb-ransac"},
                  {"pose", pose_to_json(initial ? *initial : r.guess.target_from_source)}};
  j["orb"] = {{"success", r.guess.success},
              {"failure", r.guess.failure},
              {"source_features", r.guess.source_features},
              {"target_features", r.guess.target_features},
              {"matches", r.guess.matches},
              {"inliers", r.guess.inliers},
              {"guided_matches", r.guess.guided_matches},
              {"evidence", r.guess.evidence()},
              {"inlier_rmse_m", r.guess.inlier_rmse_m},
              {"consistent_with_result", r.consistent_matches}};
  j["icp"] = icp_json(r.icp, options.icp);
  j["overlap"] = r.overlap;
  if (r.alternative_refined) j["alternative"] = runner_up_to_json(r);
  // When both panoramas were built in one frame (ground-truth poses of one scene), their stored
  // poses give the true relative pose; otherwise (tracked, each scan in its own frame) this
  // difference means nothing.
  const Rigid3d stored = target.world_from_pano.inverse() * source.world_from_pano;
  j["difference_from_stored_poses"] = {
      {"rotation_deg", rad2deg(rotation_angle(stored.linear().transpose() * r.target_from_source.linear()))},
      {"translation_m", (stored.translation() - r.target_from_source.translation()).norm()},
      {"note", "meaningful only when both panoramas were built in one frame (e.g. ground-truth poses)"}};
  j["matrix_file"] = absolute_path(matrix);
  j["seconds"] = seconds;
  write_register_outputs(a, matrix, j, r.target_from_source);
  const Eigen::Vector3d t = r.target_from_source.translation();
  std::cout << fmt::format(
      "registered {} -> {} ({}): t = ({:.4f}, {:.4f}, {:.4f}) m, rotation {:.3f} deg; initial {} ({} ORB inliers + "
      "{} guided, {} consistent at the end); {} iterations, fitness {:.2f}, {:.1f} s; wrote {} and {}\n",
      a.source, a.target, to_string(options.icp.method), t.x(), t.y(), t.z(),
      rad2deg(rotation_angle(r.target_from_source.linear())), initial ? "given" : "ORB + RANSAC", r.guess.inliers,
      r.guess.guided_matches, r.consistent_matches, r.icp.iterations, r.icp.fitness, seconds, a.out, matrix);
}

void run_recon_integrate(const ReconIntegrateArguments& a) {
  if (a.out.empty()) throw make_error("--out", "", "an output PLY file is required");
  if (a.panoramas.empty()) throw make_error("--panoramas", "", "at least one panorama folder is needed");
  Config config = load_stage2_config(a.config_file, a.overrides, a.threads);
  if (!a.method.empty()) config.set("integration.method", a.method);
  const IntegrationOptions options = integration_options_from_config(config);
  // The pixels to use (and their covariances) follow the registration's cloud settings.
  const PanoramaCloudOptions cloud_options = pair_registration_options_from_config(config).cloud;
  config.check_all_used();
  if (fs::exists(a.out) && !a.overwrite) throw make_error(a.out, "", "already exists (use --overwrite to replace it)");
  const int n = int(a.panoramas.size());
  if (n > 1 && a.poses.empty())
    throw make_error("--poses", "",
                     "give the registrations linking the panoramas (outputs of recon register), or 'stored' to use "
                     "the poses stored in the panoramas (one frame, e.g. ground-truth poses)");
  std::vector<Panorama> panoramas;
  for (const std::string& dir : a.panoramas) panoramas.push_back(read_panorama(dir));

  // Poses: the stored ones, or placed by the registrations (placement.h: the rule recon scene uses).
  std::vector<Rigid3d> world_from_panorama(n, panoramas[0].world_from_pano);
  const bool stored = a.poses.size() == 1 && a.poses[0] == "stored";
  std::string graph_report;
  std::optional<nlohmann::json> placement_record;
  if (stored) {
    for (int k = 0; k < n; ++k) world_from_panorama[k] = panoramas[k].world_from_pano;
  } else if (n > 1) {
    std::vector<PoseGraphEdge> edges;
    for (const std::string& file : a.poses) edges.push_back(read_registration_edge(file, a.panoramas));
    const Placement placement = place_panoramas(a.panoramas, panoramas[0].world_from_pano, edges, PlacementOptions());
    world_from_panorama = placement.world_from_panorama;
    placement_record = placement_to_json(a.panoramas, edges, placement);
    if (!placement.dropped.empty())
      graph_report +=
          fmt::format("; {} registration(s) dropped ({})", placement.dropped.size(), placement.dropped.front());
    if (placement.pose_graph_used)
      graph_report += fmt::format(
          "; pose graph over {} registrations: worst inconsistency {:.3f} deg / {:.1f} mm -> "
          "{:.3f} deg / {:.1f} mm",
          edges.size() - placement.dropped.size(), placement.inconsistency_chained.rotation_deg,
          placement.inconsistency_chained.translation_m * 1e3, placement.inconsistency_final.rotation_deg,
          placement.inconsistency_final.translation_m * 1e3);
  }

  const SteadyTime start = steady_now();
  std::vector<PanoramaPoints> points;
  for (int k = 0; k < n; ++k) {
    try {
      points.push_back(panorama_integration_points(panoramas[k], world_from_panorama[k], cloud_options));
    } catch (const Error& e) {
      throw make_error(a.panoramas[k], "", e.what());
    }
  }
  const IntegrationResult result = integrate_panoramas(points, options);
  const double seconds = seconds_since(start);
  PlyWriteOptions ply;
  ply.comments.push_back(fmt::format("panoscan recon integrate: {} panoramas, {}", n, to_string(options.method)));
  write_ply_point_cloud(a.out, result.cloud, ply);
  if (!a.placement_out.empty()) {
    if (!placement_record)
      placement_record = nlohmann::json{{"format", "panoscan-placement"}, {"version", 1}, {"stored", true}};
    write_file_atomic(a.placement_out, placement_record->dump(2) + "\n");
  }
  std::cout << fmt::format(
      "integrated {} panoramas ({}): {} pixels, {} mutual pairs, {} groups of {} pixels -> {} "
      "points{}; {:.1f} s; wrote {}\n",
      n, to_string(options.method), result.input_points, result.mutual_pairs, result.groups, result.grouped_points,
      result.cloud.size(), graph_report, seconds, a.out);
}

}  // namespace panoscan::app
