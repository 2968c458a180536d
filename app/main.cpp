// The panoscan command-line program: parses arguments, calls the libraries, reports.
// No algorithm lives here. Errors are exceptions, caught once below and printed on one line.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/eval/cloud_evaluation.h"
#include "panoscan/eval/report.h"
#include "panoscan/eval/trajectory_evaluation.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/scene_loader.h"
#include "panoscan/sim/simulator.h"

namespace fs = std::filesystem;
using namespace panoscan;

namespace {

// Command-line shortcuts that become config overrides, so that the config file and the
// command line share one validation path.
struct SimArguments {
  std::string scene = "office";
  std::string position = "1";
  std::string out;
  std::string config_file;
  std::vector<std::string> overrides;
  std::string resolution;
  int frames = -1;
  long long seed = -1;
  std::string noise;
  int every = -1;
  int threads = -1;
  bool clean_depth = false;
  bool overwrite = false;
};

void add_sim_options(CLI::App* cmd, SimArguments& a, bool with_scene) {
  if (with_scene) {
    cmd->add_option("--scene", a.scene, "built-in scene name (living_room, office) or a mesh file (OBJ/PLY/glTF)")
        ->capture_default_str();
    cmd->add_option("--position", a.position, "scanning position: 1-based index or name (e.g. SO-2)")
        ->capture_default_str();
  }
  cmd->add_option("--config", a.config_file, "YAML/JSON config file (keys: see README)");
  cmd->add_option("--set", a.overrides, "override a config key, e.g. --set noise.preset=kinect (repeatable)");
  cmd->add_option("--resolution", a.resolution, "image size WIDTHxHEIGHT, e.g. 640x480");
  cmd->add_option("--frames", a.frames, "frames per camera after --every (0 = the whole turn)");
  cmd->add_option("--seed", a.seed, "random seed");
  cmd->add_option("--noise", a.noise, "depth noise preset: handa, handa-icl, kinect, none (off)");
  cmd->add_option("--every", a.every, "render every n-th frame of each camera (timestamps kept)");
  cmd->add_option("--threads", a.threads, "worker threads (0 = all cores)");
  cmd->add_flag("--clean-depth", a.clean_depth, "also write noiseless depth to groundtruth/depth_clean");
  cmd->add_flag("--overwrite", a.overwrite, "replace an existing output directory");
}

SimOptions resolve_sim_options(const SimArguments& a, const std::vector<std::string>& defaults) {
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
  SimOptions options = sim_options_from_config(config);
  config.check_all_used();
  return options;
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

void run_sim(const SimArguments& a, const std::vector<std::string>& defaults) {
  if (a.out.empty()) throw make_error("--out", "", "an output directory is required");
  const SimOptions options = resolve_sim_options(a, defaults);
  const Scene scene = load_scene(a.scene);
  const int position = find_position(scene, a.position);
  const Simulator simulator(scene, position, options);
  const auto start = std::chrono::steady_clock::now();
  const std::size_t frames = simulator.write_scan(a.out, a.overwrite);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << fmt::format("wrote {} ({} {}, {} frames from {} cameras at {}x{}, noise {}, {:.1f} s, {:.1f} MB)\n",
                           a.out, scene.name, scene.positions[position].name, frames, simulator.rig().num_sensors(),
                           options.rig.width, options.rig.height, to_string(options.noise.preset), seconds,
                           directory_size(a.out) / 1e6);
}

Config load_config(const std::string& file, const std::vector<std::string>& overrides) {
  Config config = file.empty() ? Config() : Config::load_file(file);
  for (const auto& o : overrides) config.apply_override(o);
  return config;
}

struct EvalCloudArguments {
  std::string mesh, cloud, scan, coloured_ply, json, config_file;
  std::vector<std::string> viewpoints_from, overrides;
  int threads = -1;
};

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
  if (a.threads >= 0) options.threads = a.threads;
  const eval::CloudEvalReport report = eval::evaluate_cloud_files(mesh, a.cloud, options);
  std::cout << eval::cloud_report_to_text(report);
  if (!a.json.empty()) eval::write_report(a.json, eval::cloud_report_to_json(report));
}

struct EvalTrajArguments {
  std::string gt, est, json, config_file;
  std::vector<std::string> overrides;
};

void run_eval_traj(const EvalTrajArguments& a) {
  Config config = load_config(a.config_file, a.overrides);
  const eval::TrajectoryEvalOptions options = eval::trajectory_eval_options_from_config(config);
  config.check_all_used();
  const eval::TrajectoryEvalReport report = eval::evaluate_trajectory_files(a.gt, a.est, options);
  std::cout << eval::trajectory_report_to_text(report);
  if (!a.json.empty()) eval::write_report(a.json, eval::trajectory_report_to_json(report));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PanoScan: panoramic RGB-D scanning testbed (Yang et al., TOG 2020)"};
  app.require_subcommand(1);
  bool verbose = false, quiet = false;
  app.add_flag("-v,--verbose", verbose, "debug logging");
  app.add_flag("-q,--quiet", quiet, "warnings and errors only");

  // scene list | export
  CLI::App* scene_cmd = app.add_subcommand("scene", "built-in scenes: list them or export them as files");
  scene_cmd->require_subcommand(1);
  CLI::App* scene_list = scene_cmd->add_subcommand("list", "list built-in scenes and their scanning positions");
  CLI::App* scene_export = scene_cmd->add_subcommand("export", "write a scene as OBJ+MTL+PNG, ground-truth PLY, positions");
  std::string export_scene_name, export_out;
  scene_export->add_option("--scene", export_scene_name, "built-in scene name or a mesh file")->required();
  scene_export->add_option("--out", export_out, "output directory")->required();

  // sim
  SimArguments sim_args;
  CLI::App* sim_cmd = app.add_subcommand("sim", "simulate one scanning position and write the scan with ground truth");
  add_sim_options(sim_cmd, sim_args, true);
  sim_cmd->add_option("--out", sim_args.out, "output scan directory")->required();

  // demo
  SimArguments demo_args;
  demo_args.out = "panoscan-demo/office-SO-1";
  CLI::App* demo_cmd = app.add_subcommand("demo", "the main job: simulate a built-in scene at a modest size");
  demo_cmd->add_option("--out", demo_args.out, "output scan directory")->capture_default_str();
  demo_cmd->add_option("--threads", demo_args.threads, "worker threads (0 = all cores)");

  // eval cloud | traj
  CLI::App* eval_cmd = app.add_subcommand("eval", "evaluate against ground truth: clouds against meshes, trajectories");
  eval_cmd->require_subcommand(1);
  EvalCloudArguments cloud_args;
  CLI::App* eval_cloud = eval_cmd->add_subcommand("cloud", "exact distances of a point cloud (PLY) to the ground-truth mesh");
  eval_cloud->add_option("--cloud", cloud_args.cloud, "reconstructed cloud (PLY; a mesh's vertices also work)")->required();
  eval_cloud->add_option("--mesh", cloud_args.mesh, "ground-truth mesh (PLY)");
  eval_cloud->add_option("--scan", cloud_args.scan,
                         "a simulated scan: mesh from groundtruth/mesh.ply, viewpoints from groundtruth/cam*.txt");
  eval_cloud->add_option("--viewpoints-from", cloud_args.viewpoints_from,
                         "TUM trajectory whose mean centre is a viewpoint for completeness (repeatable)");
  eval_cloud->add_option("--coloured-ply", cloud_args.coloured_ply, "write the cloud coloured by its error");
  eval_cloud->add_option("--json", cloud_args.json, "write every figure and the settings as JSON");
  eval_cloud->add_option("--config", cloud_args.config_file, "YAML/JSON config (keys: see README)");
  eval_cloud->add_option("--set", cloud_args.overrides, "override a config key (repeatable)");
  eval_cloud->add_option("--threads", cloud_args.threads, "worker threads (0 = all cores)");
  EvalTrajArguments traj_args;
  CLI::App* eval_traj = eval_cmd->add_subcommand("traj", "ATE and RPE of an estimated TUM trajectory");
  eval_traj->add_option("--gt", traj_args.gt, "ground-truth TUM trajectory")->required();
  eval_traj->add_option("--est", traj_args.est, "estimated TUM trajectory")->required();
  eval_traj->add_option("--json", traj_args.json, "write every figure and the settings as JSON");
  eval_traj->add_option("--config", traj_args.config_file, "YAML/JSON config (keys: see README)");
  eval_traj->add_option("--set", traj_args.overrides, "override a config key (repeatable)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (verbose) set_log_level(LogLevel::kDebug);
  if (quiet) set_log_level(LogLevel::kWarn);

  try {
    if (*scene_list) {
      for (const std::string& name : scenes::builtin_scene_names()) {
        const Scene scene = scenes::make_builtin_scene(name);
        std::cout << fmt::format("{}: {} triangles, {} materials, {} textures, positions:", name,
                                 scene.mesh.num_triangles(), scene.materials.size(), scene.textures.size());
        for (const auto& p : scene.positions)
          std::cout << fmt::format(" {} ({:.2f}, {:.2f})", p.name, p.floor_point.x(), p.floor_point.y());
        std::cout << "\n";
      }
    } else if (*scene_export) {
      const Scene scene = load_scene(export_scene_name);
      scenes::export_scene(scene, export_out);
      std::cout << fmt::format("exported {} ({} triangles) to {}\n", scene.name, scene.mesh.num_triangles(), export_out);
    } else if (*sim_cmd) {
      run_sim(sim_args, {});
    } else if (*eval_cloud) {
      run_eval_cloud(cloud_args);
    } else if (*eval_traj) {
      run_eval_traj(traj_args);
    } else if (*demo_cmd) {
      // A modest size: the office, position 1, every 10th frame of the full turn (~300 frames).
      demo_args.scene = "office";
      demo_args.position = "1";
      demo_args.overwrite = true;
      run_sim(demo_args, {"output.every=10"});
    }
  } catch (const Error& e) {
    std::cerr << "panoscan: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "panoscan: unexpected error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
