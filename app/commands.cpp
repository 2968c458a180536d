#include "commands.h"
#include "command_support.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/timer.h"
#include "panoscan/core/atomic_output.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/image_io.h"
#include "panoscan/eval/cloud_evaluation.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/image_texture.h"
#include "panoscan/eval/report.h"
#include "panoscan/eval/trajectory_evaluation.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/eval/html_report.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/placement.h"
#include "panoscan/recon/poses.h"
#include "panoscan/recon/scene.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/scene_loader.h"
#include "panoscan/sim/simulator.h"
#include "panoscan/tables/tables.h"

namespace fs = std::filesystem;

namespace panoscan::app {

namespace {

// The sim's options and the scene's style (scene.texture), from one config.
struct ResolvedSim {
  SimOptions options;
  scenes::SceneStyle style;
  bool style_given = false;
};

ResolvedSim resolve_sim_options(const SimArguments& a, const std::vector<std::string>& defaults) {
  Config config = a.config_file.empty() ? Config() : Config::load_file(a.config_file);
  for (const auto& d : defaults)
    if (!config.has(d.substr(0, d.find('=')))) config.apply_override(d);
  for (const auto& o : a.overrides) config.apply_override(o);
  if (!a.resolution.empty()) {
    int width = 0, height = 0;
    char separator = 0;
    if (std::sscanf(a.resolution.c_str(), "%d%c%d", &width, &separator, &height) != 3 || separator != 'x')
      throw make_error("--resolution", "", "expected WIDTHxHEIGHT, got '" + a.resolution + "'");
    config.set("camera.width", std::to_string(width));
    config.set("camera.height", std::to_string(height));
  }
  if (a.frames >= 0) config.set("output.frames", std::to_string(a.frames));
  if (a.seed >= 0) config.set("seed", std::to_string(a.seed));
  if (!a.noise.empty()) config.set("noise.preset", a.noise == "off" ? "none" : a.noise);
  if (a.every >= 0) config.set("output.every", std::to_string(a.every));
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  if (a.clean_depth) config.set("output.clean_depth", "true");
  if (a.normals) config.set("output.normals", "true");
  if (a.ids) config.set("output.ids", "true");
  ResolvedSim resolved;
  resolved.options = sim_options_from_config(config);
  resolved.style_given = config.has("scene.texture");
  resolved.style = scenes::scene_style_from_config(config);
  config.check_all_used();
  return resolved;
}

int find_position(const Scene& scene, const std::string& position) {
  for (std::size_t i = 0; i < scene.positions.size(); ++i)
    if (scene.positions[i].name == position) return int(i);
  try {
    std::size_t used = 0;
    const int index = std::stoi(position, &used);
    if (used == position.size()) return index - 1;  // validated by the simulator
  } catch (const std::exception&) {
  }
  std::string names;
  for (const auto& p : scene.positions) names += (names.empty() ? "" : ", ") + p.name;
  throw make_error("--position", "", "'" + position + "' is neither an index nor one of: " + names);
}

std::uintmax_t directory_size(const fs::path& dir) {
  std::uintmax_t bytes = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.is_regular_file()) bytes += entry.file_size();
  return bytes;
}

}  // namespace

Config load_config(const std::string& file, const std::vector<std::string>& overrides) {
  Config config = file.empty() ? Config() : Config::load_file(file);
  for (const auto& o : overrides) config.apply_override(o);
  return config;
}

void run_sim(const SimArguments& a, const std::vector<std::string>& defaults) {
  if (a.out.empty()) throw make_error("--out", "", "an output directory is required");
  const ResolvedSim resolved = resolve_sim_options(a, defaults);
  const SimOptions& options = resolved.options;
  const Scene scene = load_scene(a.scene, resolved.style, resolved.style_given);
  const int position = find_position(scene, a.position);
  const Simulator simulator(scene, position, options);
  const auto start = std::chrono::steady_clock::now();
  SimStageTimes times;
  const std::size_t frames = simulator.write_scan(a.out, a.overwrite, &times);
  const double seconds = seconds_since(start);
  std::cout << fmt::format("wrote {} ({} {}, {} frames from {} cameras at {}x{}, noise {}, {:.1f} s, {:.1f} MB)\n",
                           a.out, scene.name, scene.positions[position].name, frames, simulator.rig().num_sensors(),
                           options.rig.width, options.rig.height, to_string(options.noise.preset), seconds,
                           directory_size(a.out) / 1e6);
  // Where the time went (sim/README.md explains the stages).
  log_info("sim: " + times.summary());
}

void run_eval_cloud(const EvalCloudArguments& a) {
  std::string mesh = a.mesh;
  std::vector<fs::path> viewpoints(a.viewpoints_from.begin(), a.viewpoints_from.end());
  if (!a.scan.empty()) {
    // A simulated scan brings its ground truth: the mesh and the camera trajectories (viewpoints).
    const fs::path truth = fs::path(a.scan) / "groundtruth";
    if (mesh.empty()) mesh = (truth / "mesh.ply").string();
    if (viewpoints.empty() && fs::is_directory(truth))
      for (const auto& entry : fs::directory_iterator(truth))
        if (entry.path().extension() == ".txt") viewpoints.push_back(entry.path());
    std::sort(viewpoints.begin(), viewpoints.end());
  }
  if (mesh.empty()) throw make_error("--mesh", "", "a ground-truth mesh is required (--mesh or --scan)");
  Config config = load_config(a.config_file, a.overrides);
  eval::CloudEvalOptions options = eval::cloud_eval_options_from_config(config);
  config.check_all_used();
  options.viewpoint_trajectories = viewpoints;
  options.coloured_ply = a.coloured_ply;
  if (!a.transform.empty()) options.scene_from_cloud = read_pose_file(a.transform);
  if (a.threads >= 0) options.threads = a.threads;
  const eval::CloudEvalReport report = eval::evaluate_cloud_files(mesh, a.cloud, options);
  std::cout << eval::cloud_report_to_text(report);
  if (!a.json.empty()) eval::write_report(a.json, eval::cloud_report_to_json(report));
}

void run_eval_flat(const EvalFlatArguments& a) {
  if (a.panorama.empty() == a.image.empty())
    throw make_error("--panorama", "", "give exactly one of --panorama (a panorama folder) or --image");
  ImageF32 grey;
  ImageU8 valid;
  if (!a.panorama.empty()) {
    const Panorama panorama = read_panorama(a.panorama);
    grey = eval::grey_levels_from_unit(panorama.colour);
    valid = ImageU8(panorama.depth.width, panorama.depth.height, 1, 0);
    for (std::size_t i = 0; i < valid.data.size(); ++i) valid.data[i] = panorama.depth.data[i] > 0.f;
  } else {
    grey = eval::grey_levels(read_rgb(a.image));
  }
  const eval::FlatPixelShare share = eval::flat_pixel_share(grey, valid, a.window, a.threshold);
  std::cout << fmt::format("{}: {:.1f}% of {} valid pixels flat (grey-level std < {} over {}x{})\n",
                           a.panorama.empty() ? a.image : a.panorama, 100.0 * share.share, share.valid_pixels,
                           a.threshold, a.window, a.window);
  if (!a.json.empty()) {
    nlohmann::json j = {{"input", a.panorama.empty() ? a.image : a.panorama},
                        {"window", a.window},
                        {"std_threshold", a.threshold},
                        {"valid_pixels", share.valid_pixels},
                        {"flat_pixels", share.flat_pixels},
                        {"flat_share", share.share}};
    write_file_atomic(a.json, j.dump(2) + "\n");
  }
}

void run_eval_traj(const EvalTrajArguments& a) {
  Config config = load_config(a.config_file, a.overrides);
  const eval::TrajectoryEvalOptions options = eval::trajectory_eval_options_from_config(config);
  config.check_all_used();
  const eval::TrajectoryEvalReport report = eval::evaluate_trajectory_files(a.gt, a.est, options);
  std::cout << eval::trajectory_report_to_text(report);
  if (!a.json.empty()) eval::write_report(a.json, eval::trajectory_report_to_json(report));
}

void run_scene_list() {
  for (const std::string& name : scenes::builtin_scene_names()) {
    const Scene scene = scenes::make_builtin_scene(name);
    std::cout << fmt::format("{}: {} triangles, {} materials, {} textures, positions:", name,
                             scene.mesh.num_triangles(), scene.materials.size(), scene.textures.size());
    for (const auto& p : scene.positions)
      std::cout << fmt::format(" {} ({:.2f}, {:.2f})", p.name, p.floor_point.x(), p.floor_point.y());
    std::cout << "\n";
  }
}

void run_scene_export(const SceneExportArguments& a) {
  Config config = load_config(a.config_file, a.overrides);
  const bool style_given = config.has("scene.texture");
  const scenes::SceneStyle style = scenes::scene_style_from_config(config);
  config.check_all_used();
  const std::string& scene_name = a.scene;
  const std::string& out = a.out;
  const Scene scene = load_scene(scene_name, style, style_given);
  scenes::export_scene(scene, out);
  std::cout << fmt::format("exported {} ({} triangles) to {}\n", scene.name, scene.mesh.num_triangles(), out);
}

void run_scene_generate(const SceneGenerateArguments& a) {
  if (a.out.empty()) throw make_error("--out", "", "an output directory is required");
  if (a.seed < 0) throw make_error("--seed", "", "a seed >= 0 is required");
  Config config = load_config(a.config_file, a.overrides);
  if (!a.texture.empty()) config.set("scene.texture", a.texture);
  scenes::RoomSpec spec;
  spec.style = scenes::scene_style_from_config(config);
  config.check_all_used();
  spec.kind = scenes::room_kind_from_string(a.kind, "--kind");
  spec.seed = static_cast<std::uint64_t>(a.seed);
  const scenes::GeneratedRoom room = scenes::generate_room(spec);
  scenes::export_scene(room.scene, a.out);
  Eigen::Vector2f lo = room.outline.front(), hi = lo;
  for (const auto& corner : room.outline) {
    lo = lo.cwiseMin(corner);
    hi = hi.cwiseMax(corner);
  }
  std::cout << fmt::format(
      "generated {} ({}, {:.2f} x {:.2f} m, {:.2f} m high, texture {}): {} triangles, {} pieces "
      "placed; positions:",
      room.scene.name, room.outline.size() == 6 ? "L-shaped" : "rectangular", hi.x() - lo.x(), hi.y() - lo.y(),
      room.height, scenes::to_string(spec.style.texture), room.scene.mesh.num_triangles(), room.furniture.size());
  for (std::size_t i = 0; i < room.scene.positions.size(); ++i) {
    const auto& p = room.scene.positions[i];
    std::cout << fmt::format(" {} ({:.2f}, {:.2f}; clearance {:.2f} m)", p.name, p.floor_point.x(), p.floor_point.y(),
                             room.clearance_m[i]);
  }
  std::cout << fmt::format("\nwrote {}/{}.obj (+ .mtl, textures/, _groundtruth.ply, .positions.json)\n", a.out,
                           room.scene.name);
}

void run_recon_track(const ReconTrackArguments& a) {
  Config config = load_config(a.config_file, a.overrides);
  if (!a.mode.empty()) config.set("track.mode", a.mode);
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  if (a.allow_unreliable) config.set("track.allow_unreliable", "true");
  const TrackingOptions options = tracking_options_from_config(config);
  config.check_all_used();
  if (fs::exists(a.out) && !a.overwrite) throw make_error(a.out, "", "already exists (use --overwrite to replace it)");
  const ScanIndex scan = read_scan_index(a.scan);
  const TrackingResult result = track_scan(scan, options);
  require_reliable_tracking(result, options, a.scan);
  write_tracking_result(a.out, result, scan.rig, a.scan);
  const TrackingStats& s = result.stats;
  std::cout << fmt::format("tracked {} ({}): {} iterations, cost {:.4g} -> {:.4g}, {}; wrote {}\n", a.scan,
                           to_string(options.mode), s.iterations, s.initial_cost, s.final_cost,
                           s.converged ? "converged" : "NOT converged", a.out);
  if (!result.verdict.reliable)
    std::cout << fmt::format(
        "UNRELIABLE (kept for inspection, marked in rig_estimate.json and tracking_stats.json): {}\n",
        result.verdict.first_failure());
}

namespace {

void refuse_existing(const std::string& out, bool overwrite) {
  if (fs::exists(out) && !overwrite) throw make_error(out, "", "already exists (use --overwrite to replace it)");
}

// Scene frame of a simulated scan from the frame of a reconstruction that used `trajectory` for
// it: the reference camera's first frame is where both agree.
Rigid3d scene_from_reconstruction(const std::string& scan_dir, const RigTrajectory& trajectory, int reference) {
  return eval::scene_from_reconstruction(eval::groundtruth_rig_trajectory(scan_dir).world_from_cam[reference],
                                         trajectory.world_from_cam[reference]);
}

PointCloud transformed(const PointCloud& cloud, const Rigid3d& b_from_a) {
  PointCloud out = cloud;
  for (auto& p : out.positions) p = b_from_a * p;
  return out;
}

}  // namespace

void run_recon_panorama(const ReconPanoramaArguments& a) {
  Config config = load_config(a.config_file, a.overrides);
  if (!a.method.empty()) config.set("panorama.method", a.method);
  if (a.height > 0) config.set("panorama.height", std::to_string(a.height));
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  const PanoramaOptions options = panorama_options_from_config(config);
  const TrackingOptions tracking = tracking_options_from_config(config);
  config.check_all_used();
  refuse_existing(a.out, a.overwrite);
  const ScanIndex scan = read_scan_index(a.scan);
  const RigTrajectory trajectory = scan_poses(a.poses, a.scan, scan, tracking);
  const PanoramaResult result = build_panorama(scan, trajectory, options);
  write_panorama(a.out, result.panorama, a.overwrite);
  std::cout << fmt::format(
      "panorama {}x{} ({}, lambda {:.3g}) from {} frames: {} measurements ({:.1f} MB), warp "
      "{:.1f} s, fusion {:.1f} s; wrote {}\n",
      result.panorama.pano.width(), result.panorama.pano.height, result.panorama.method, result.panorama.lambda,
      result.frames_used, result.measurements, result.measurement_bytes / 1e6, result.warp_seconds,
      result.fusion_seconds, a.out);
}

void run_recon_scene(const ReconSceneArguments& a) {
  if (a.scans.empty()) throw make_error("--scans", "", "at least one scan is needed");
  Config config = load_config(a.config_file, a.overrides);
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  const SceneOptions options = scene_options_from_config(config);
  config.check_all_used();
  refuse_existing(a.out, a.overwrite);
  if (a.poses != "tracked" && a.poses != "ground-truth")
    throw make_error("--poses", "", "expected tracked or ground-truth, got '" + a.poses + "'");
  std::vector<SceneScan> scans;
  for (const std::string& dir : a.scans) {
    SceneScan s;
    s.name = fs::path(dir).filename().string();
    s.scan = read_scan_index(dir);
    if (a.poses == "ground-truth") s.trajectory = eval::groundtruth_rig_trajectory(dir);
    scans.push_back(std::move(s));
  }
  const SceneResult result = reconstruct_scene(scans, options);
  PointCloud cloud = result.integration.cloud;
  if (a.align_to_ground_truth && a.poses == "tracked")
    cloud = transformed(
        cloud, scene_from_reconstruction(a.scans[0], result.trajectories[0], scans[0].scan.rig.reference_sensor));
  // Everything goes into a temporary sibling folder that replaces `out` only when complete.
  AtomicDirectory output(a.out, a.overwrite);
  write_ply_point_cloud(output.temp_path() / "cloud.ply", cloud);
  for (std::size_t k = 0; k < scans.size(); ++k) {
    write_panorama(output.temp_path() / (scans[k].name + "-panorama"), result.panoramas[k], false);
    write_rig_trajectory(output.temp_path() / (scans[k].name + "-poses"), result.trajectories[k], scans[k].scan.rig);
  }
  std::vector<std::string> names;
  for (const SceneScan& s : scans) names.push_back(s.name);
  write_file_atomic(output.temp_path() / "placement.json",
                    placement_to_json(names, result.registrations, result.placement).dump(2) + "\n");
  write_file_atomic(output.temp_path() / "registrations.json",
                    scene_registrations_to_json(names, result).dump(2) + "\n");
  // Where the time went (scripts/whole_office.py reads it): wall-clock seconds per stage.
  const nlohmann::json timings = {
      {"tracking_s", result.seconds_tracking},
      {"panorama_s", result.seconds_panorama},
      {"registration_s", result.seconds_registration - result.seconds_pose_graph},
      {"pose_graph_s", result.seconds_pose_graph},
      {"integration_s", result.seconds_integration},
      {"scans", scans.size()},
      {"written_by", {{"version", project_version()}, {"source_revision", source_revision()}}}};
  write_file_atomic(output.temp_path() / "timings.json", timings.dump(2) + "\n");
  output.commit();
  std::cout << fmt::format(
      "scene of {} scans: {} registrations ({} skipped{}), {} points ({} merged groups); "
      "times: tracking {:.1f} s, panoramas {:.1f} s, registration {:.1f} s, integration {:.1f} s; "
      "wrote {}/cloud.ply\n",
      scans.size(), result.edges.size(), result.skipped_pairs.size(), result.pose_graph_used ? ", pose graph" : "",
      cloud.size(), result.integration.groups, result.seconds_tracking, result.seconds_panorama,
      result.seconds_registration, result.seconds_integration, a.out);
}

void run_demo(const DemoArguments& a) {
  const auto start = std::chrono::steady_clock::now();
  // 1. Simulate two scanning positions of the office at a modest size.
  const Scene scene = scenes::make_builtin_scene("office");
  SimOptions sim;
  sim.rig.width = 320;
  sim.rig.height = 240;
  sim.output.every = 16;
  if (a.threads >= 0) sim.threads = a.threads;
  std::vector<SceneScan> scans;
  std::vector<std::string> dirs;
  for (int position : {0, 2}) {
    const std::string dir = (fs::path(a.out) / scene.positions[position].name).string();
    Simulator(scene, position, sim).write_scan(dir, true);
    dirs.push_back(dir);
    SceneScan s;
    s.name = scene.positions[position].name;
    s.scan = read_scan_index(dir);
    scans.push_back(std::move(s));
  }
  // 2. Reconstruct: tracking, panoramas (TSA, H = 512), registration (GICP with the measured variance).
  Config config;
  config.set("panorama.height", "512");
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  SceneOptions options = scene_options_from_config(config);
  options.registration.cloud.pixel_stride = 2;
  const SceneResult result = reconstruct_scene(scans, options);
  // 3. Integrate three ways and evaluate against the mesh (in the scene frame).
  const Rigid3d scene_from_recon =
      scene_from_reconstruction(dirs[0], result.trajectories[0], scans[0].scan.rig.reference_sensor);
  std::vector<PanoramaPoints> points;
  for (std::size_t k = 0; k < scans.size(); ++k)
    points.push_back(
        panorama_integration_points(result.panoramas[k], result.world_from_panorama[k], options.registration.cloud));
  const eval::MeshDistance mesh(scene.mesh, "office");
  std::cout << fmt::format("\nPanoScan demo: office {} + {}, 320x240, every 16th frame, tracked poses, TSA panoramas\n",
                           scans[0].name, scans[1].name);
  std::cout << "| integration | points | RMSE (mm) | mean (mm) | median (mm) |\n|---|---|---|---|---|\n";
  eval::ResultTable table;
  table.title = fmt::format("Demo: distance of each integration's cloud to the ground-truth mesh (office {} + {})",
                            scans[0].name, scans[1].name);
  table.decimals = 2;
  std::vector<std::string> notes;
  for (MergeMethod method : {MergeMethod::kAlignOnly, MergeMethod::kAverage, MergeMethod::kMap}) {
    IntegrationOptions integration = options.integration;
    integration.method = method;
    const PointCloud cloud = transformed(integrate_panoramas(points, integration).cloud, scene_from_recon);
    const eval::ErrorStats d = eval::summarize_errors(mesh.distances(cloud.positions));
    std::cout << fmt::format("| {} | {} | {:.2f} | {:.2f} | {:.2f} |\n", to_string(method), cloud.size(), d.rmse * 1e3,
                             d.mean * 1e3, d.median * 1e3);
    table.set(to_string(method), "RMSE", d.rmse * 1e3);
    table.set(to_string(method), "mean", d.mean * 1e3);
    table.set(to_string(method), "median", d.median * 1e3);
    notes.push_back(fmt::format("{}: {} points, cloud-{}.ply", to_string(method), cloud.size(), to_string(method)));
    write_ply_point_cloud(fs::path(a.out) / (std::string("cloud-") + to_string(method) + ".ply"), cloud);
  }
  // The panoramas and tracked poses beside the scans, for the report (like recon scene's output).
  for (std::size_t k = 0; k < scans.size(); ++k) {
    write_panorama(fs::path(a.out) / (scans[k].name + "-panorama"), result.panoramas[k], true);
    fs::create_directories(fs::path(a.out) / (scans[k].name + "-poses"));
    write_rig_trajectory(fs::path(a.out) / (scans[k].name + "-poses"), result.trajectories[k], scans[k].scan.rig);
  }
  const double seconds = seconds_since(start);
  notes.push_back(fmt::format("{} registration(s); times: tracking {:.1f} s, panoramas {:.1f} s, registration {:.1f} s",
                              result.edges.size(), result.seconds_tracking, result.seconds_panorama,
                              result.seconds_registration));
  // The table as a record in the table drivers' layout (<name>.md, <name>.json), so that the
  // report shows it like theirs.
  std::string markdown = eval::table_to_markdown(table) + "\nNotes:\n";
  for (const auto& n : notes) markdown += "- " + n + "\n";
  write_file_atomic(fs::path(a.out) / "demo.md", markdown);
  nlohmann::json values = nlohmann::json::object();
  for (std::size_t m = 0; m < table.methods.size(); ++m)
    for (std::size_t c = 0; c < table.scans.size(); ++c) values[table.methods[m]][table.scans[c]] = table.values[m][c];
  nlohmann::json record = {
      {"table", "demo"},
      {"description", "panoscan demo: office SO-1 + SO-3 simulated, tracked, TSA panoramas, registered, integrated"},
      {"version", project_version()},
      {"source_revision", source_revision()},
      {"seconds", seconds},
      {"settings",
       {{"scene", "office"},
        {"positions", {scans[0].name, scans[1].name}},
        {"width", sim.rig.width},
        {"height", sim.rig.height},
        {"every", sim.output.every},
        {"noise", to_string(sim.noise.preset)},
        {"poses", "tracked"},
        {"panorama_height", 512},
        {"threads", a.threads >= 0 ? a.threads : 0}}},  // 0 = all cores
      {"tables", {{{"title", table.title}, {"unit", table.unit}, {"lower_is_better", true}, {"values", values}}}},
      {"notes", notes}};
  write_file_atomic(fs::path(a.out) / "demo.json", record.dump(2) + "\n");
  const fs::path report = fs::path(a.out) / "report.html";
  eval::HtmlReportOptions report_options;
  report_options.title = "PanoScan demo";
  eval::write_html_report({fs::path(a.out)}, report, report_options);
  std::cout << fmt::format(
      "\n{} registration(s); times: tracking {:.1f} s, panoramas {:.1f} s, registration {:.1f} s; "
      "total {:.0f} s. Scans, panoramas, poses and clouds in {}/\nreport: {}\n",
      result.edges.size(), result.seconds_tracking, result.seconds_panorama, result.seconds_registration, seconds,
      a.out, report.string());
}

void run_tables(const TablesArguments& a) {
  if (a.names.size() == 1 && a.names[0] == "list") {
    for (const auto& d : tables::table_drivers()) std::cout << fmt::format("{:8} {}\n", d.name, d.description);
    return;
  }
  if (a.names[0] == "merge") {
    // tables merge RECORD... --out DIR: the records' statistics, nothing re-run.
    if (a.names.size() < 2) throw make_error("tables merge", "records", "give the run records or folders to merge");
    const std::vector<fs::path> records(a.names.begin() + 1, a.names.end());
    for (const fs::path& dir : tables::merge_and_write(records, a.out)) std::cout << dir.string() << "\n";
    std::cout << (fs::path(a.out) / "claims.md").string() << "\n";
    return;
  }
  const bool scan_only = a.names[0] == "scan";
  const bool columns_only = a.names[0] == "columns";
  if (columns_only && a.names.size() != 2) throw make_error("tables columns", "names", "give one table (e.g. table4)");
  if (scan_only && a.names.size() < 2) throw make_error("tables scan", "labels", "give the scan labels (e.g. SO-1)");
  if (!a.seeds.empty() && a.seed != 1) throw make_error("--seeds", a.seeds, "give --seed or --seeds, not both");
  const std::vector<std::uint64_t> seeds =
      a.seeds.empty() ? std::vector<std::uint64_t>{std::uint64_t(std::max(a.seed, 0LL))} : tables::parse_seed_list(a.seeds);
  std::vector<std::string> names;
  for (const auto& n : a.names) {
    if (scan_only) break;
    if (columns_only && n == "columns") continue;
    if (n == "all") {
      for (const auto& d : tables::table_drivers()) names.push_back(d.name);
    } else {
      tables::table_driver(n);  // validates the name before any work
      names.push_back(n);
    }
  }
  tables::size_preset(a.size);
  const std::vector<std::string> noises =
      a.noise == "both" ? std::vector<std::string>{"handa", "kinect"} : std::vector<std::string>{a.noise};
  if (a.seed < 0) throw make_error("--seed", "", "must not be negative");
  // --set: only the scene's style applies to the tables (their sim settings are the size preset's).
  Config config = load_config("", a.overrides);
  const std::string texture = scenes::to_string(scenes::scene_style_from_config(config).texture);
  config.check_all_used();
  std::vector<tables::TablesOptions> runs;
  for (const auto& noise : noises) {
    tables::TablesOptions options;
    options.size = a.size;
    options.noise = noise;
    options.out = fs::path(a.out) / noise;
    options.cache = a.cache.empty() ? fs::path(a.out) / "scans" : fs::path(a.cache);
    options.threads = a.threads;
    options.seed = std::uint64_t(a.seed);
    options.only = a.only;
    options.record_refusals = a.record_refusals;
    options.texture = texture;
    if (!a.scenes.empty()) options.scenes = a.scenes;
    tables::check_tables_options(options);  // every run is checked before the first starts
    runs.push_back(options);
  }
  if (columns_only) {
    // tables columns NAME: one line per column, "LABEL SCAN...", for a workflow to schedule the
    // simulations and one run per column (--only LABEL).
    for (const auto& column : tables::table_driver(names.front()).columns(runs.front()))
      std::cout << column.label << (column.scans.empty() ? "" : " ") << fmt::format("{}", fmt::join(column.scans, " "))
                << "\n";
    return;
  }
  if (scan_only) {
    // tables scan LABEL...: the scans a table run would simulate, into the cache (a workflow's first
    // job), one line per scan folder.
    for (auto options : runs)
      for (std::uint64_t seed : seeds) {
        options.seed = seed;
        for (auto it = a.names.begin() + 1; it != a.names.end(); ++it)
          std::cout << tables::cached_scan(*it, options).string() << "\n";
      }
    return;
  }
  for (const auto& options : runs)
    for (const auto& name : names) {
      if (seeds.size() > 1) {
        tables::run_seeds_and_write(name, options, seeds);
        const fs::path merged = options.out / name / (name + ".md");
        std::ifstream text(merged);
        std::cout << text.rdbuf() << "\n(" << merged.string() << ")\n";
        continue;
      }
      tables::TablesOptions one = options;
      one.seed = seeds.front();
      const tables::TableRun run = tables::run_and_write(name, one);
      for (const auto& t : run.tables) std::cout << eval::table_to_markdown(t) << "\n";
      for (const auto& note : run.notes) std::cout << "- " << note << "\n";
    }
}

}  // namespace panoscan::app
