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
  bool normals = false;
  bool ids = false;
  bool overwrite = false;
};
// `defaults` are "key=value" settings applied unless the config file sets the key.
void run_sim(const SimArguments& arguments, const std::vector<std::string>& defaults);

void run_scene_list();
struct SceneExportArguments {
  std::string scene, out, config_file;
  std::vector<std::string> overrides;  // scene.texture (built-in scenes)
};
void run_scene_export(const SceneExportArguments& arguments);

struct SceneGenerateArguments {
  std::string kind, out, texture, config_file;  // texture: shortcut for --set scene.texture=
  long long seed = -1;
  std::vector<std::string> overrides;
};
// Generates a room (scenes::generate_room) and exports it like `scene export`.
void run_scene_generate(const SceneGenerateArguments& arguments);

struct EvalCloudArguments {
  std::string mesh, cloud, scan, coloured_ply, json, config_file;
  std::string transform;  // scene_from_cloud (read_pose_file), applied before the evaluation
  std::vector<std::string> viewpoints_from, overrides;
  int threads = -1;
};
void run_eval_cloud(const EvalCloudArguments& arguments);

struct EvalFlatArguments {
  std::string panorama, image, json;  // one of panorama (a `recon panorama` folder) or image (PNG/JPEG)
  int window = 7;
  double threshold = 2.0;
};
// Share of flat pixels (grey-level std < threshold over window x window) among the valid ones.
void run_eval_flat(const EvalFlatArguments& arguments);

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
  bool allow_unreliable = false;  // write a trajectory that fails its self-check (marked as such)
};
void run_recon_track(const ReconTrackArguments& arguments);

struct ReconPanoramaArguments {
  std::string scan, poses = "tracked", out, method, config_file;
  std::vector<std::string> overrides;
  int height = -1;
  int threads = -1;
  bool overwrite = false;
};
// --poses: "ground-truth" (a simulated scan's truth), a rig-trajectory folder (from recon track),
// or "tracked" (track first).
void run_recon_panorama(const ReconPanoramaArguments& arguments);

struct ReconSceneArguments {
  std::vector<std::string> scans;
  std::string poses = "tracked";  // or "ground-truth"
  std::string out, config_file;
  std::vector<std::string> overrides;
  int threads = -1;
  bool align_to_ground_truth = false;
  bool overwrite = false;
};
void run_recon_scene(const ReconSceneArguments& arguments);

// recon register / recon integrate (commands_stage2.cpp): stage 2 on panorama folders written by
// `recon panorama` (or `recon scene`); recon register also on point-cloud files (.ply, .pcd).
struct ReconRegisterArguments {
  std::string source, target;  // panorama folders, or point-cloud files (.ply / .pcd)
  std::string method;          // registration.method (default gicp-ours)
  std::string initial;         // optional: a pose JSON, a previous `recon register` output, or a 4x4 .txt
  std::string matrix;          // the 4x4 text output; default: --out with .txt for .json
  double voxel_m = -1;         // clouds: registration.voxel_m (< 0: from the config)
  std::string out, config_file;
  std::vector<std::string> overrides;
  int threads = -1;
  bool overwrite = false;
};
void run_recon_register(const ReconRegisterArguments& arguments);

struct ReconIntegrateArguments {
  std::vector<std::string> panoramas;  // panorama folders; the first one fixes the frame
  std::vector<std::string> poses;      // `recon register` outputs linking them, or "stored"
  std::string method;                  // integration.method: map (default), average, align
  std::string out, config_file;        // out: cloud.ply
  std::string placement_out;           // optional: the panoramas' poses (placement.h's JSON)
  std::vector<std::string> overrides;
  int threads = -1;
  bool overwrite = false;
};
void run_recon_integrate(const ReconIntegrateArguments& arguments);

// import tum (commands_import.cpp): TUM RGB-D sequences, one per sensor, into a scan folder
// (core/tum_import.h).
struct ImportTumArguments {
  std::vector<std::string> inputs;      // sensor K = the K-th --input
  std::string out, extrinsics;
  std::vector<std::string> intrinsics;  // "fx,fy,cx,cy": once, or once per input
  std::vector<std::string> cameras;     // presets fr1|fr2|fr3|ros: once, or once per input
  std::string motion = "handheld";
  double depth_scale = 5000.0;
  double max_dt = 0.02;
  bool hard_link = false;
  bool overwrite = false;
};
void run_import_tum(const ImportTumArguments& arguments);

// export prestitched|colmap|nerfstudio (commands_export.cpp; export/exports.h).
struct ExportPrestitchedArguments {
  std::string scan, out, stitch = "ex";
  int width = 0, height = 0;  // 0: the reference camera's width, twice that
  int threads = -1;
  bool overwrite = false;
};
void run_export_prestitched(const ExportPrestitchedArguments& arguments);

struct ExportModelArguments {
  std::string scan, out, poses = "ground-truth", config_file;
  std::vector<std::string> panoramas;  // colmap only: panorama folders instead of a scan
  std::vector<std::string> overrides;
  int points_per_image = 100;  // colmap only
  int threads = -1;
  bool overwrite = false;
};
void run_export_colmap(const ExportModelArguments& arguments);
void run_export_nerfstudio(const ExportModelArguments& arguments);

struct DemoArguments {
  std::string out = "panoscan-demo";
  int threads = -1;
};
// Simulates office SO-1 and SO-3, reconstructs the scene with tracked poses and prints the RMSE
// of align-only / average / MAP integration against the ground-truth mesh; writes the scans, the
// panoramas, the tracked poses, the clouds, the table as a record (demo.md, demo.json) and
// report.html, and prints the report's path.
void run_demo(const DemoArguments& arguments);

struct ReportArguments {
  std::vector<std::string> results;  // result folders (or eval/table JSON files)
  std::string out = "report.html";
  std::string title;                 // default: "PanoScan results"
};
// One self-contained HTML page of what the result folders hold (eval/html_report.h).
void run_report(const ReportArguments& arguments);

struct TablesArguments {
  std::vector<std::string> names;  // table names, "all" or "list"
  std::string size = "quick";
  std::string noise = "handa";  // a preset, or "both" (handa then kinect)
  std::string out = "panoscan-tables";
  std::string cache;
  std::vector<std::string> only;
  long long seed = 1;
  std::string seeds;                   // --seeds 1-8: one run per seed, then the merged statistics
  std::vector<std::string> scenes;     // --scenes builtin | generated:N | FILE (default builtin)
  int threads = 0;
  std::vector<std::string> overrides;  // --set: scene.texture
  bool record_refusals = false;        // a stage's refusal is the run's recorded outcome (the workflow's parts)
};
// Runs the table drivers (benchmarks/tables) and writes <out>/<noise>/<name>/<name>.{md,csv,json};
// `tables merge RECORDS...` merges run records, `tables scan LABELS...` fills the scan cache.
void run_tables(const TablesArguments& arguments);

}  // namespace panoscan::app
