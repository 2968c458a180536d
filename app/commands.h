// The subcommands of the panoscan program behind plain argument structs, so that CLI11 (slow to
// compile) stays in main.cpp. Each run_* reads files, calls the libraries and reports; no
// algorithm lives here. Errors are panoscan::Error, caught in main.
#pragma once

#include <string>
#include <vector>

namespace panoscan::app {

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
// `defaults` are "key=value" settings applied unless the config file sets the key.
void run_sim(const SimArguments& arguments, const std::vector<std::string>& defaults);

void run_scene_list();
void run_scene_export(const std::string& scene, const std::string& out);

struct EvalCloudArguments {
  std::string mesh, cloud, scan, coloured_ply, json, config_file;
  std::vector<std::string> viewpoints_from, overrides;
  int threads = -1;
};
void run_eval_cloud(const EvalCloudArguments& arguments);

struct EvalTrajArguments {
  std::string gt, est, json, config_file;
  std::vector<std::string> overrides;
};
void run_eval_traj(const EvalTrajArguments& arguments);

struct ReconTrackArguments {
  std::string scan, out, mode, config_file;
  std::vector<std::string> overrides;
  int threads = -1;
  bool overwrite = false;
};
void run_recon_track(const ReconTrackArguments& arguments);

}  // namespace panoscan::app
