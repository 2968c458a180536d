// The panoscan command-line program: parses arguments, calls the libraries, reports.
// No algorithm lives here. Errors are exceptions, caught once below and printed on one line.
#include <algorithm>
#include <cstdlib>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "panoscan/core/process.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/cpu_features.h"
#include "panoscan/core/version.h"
#include "commands.h"

namespace fs = std::filesystem;
using namespace panoscan;
using namespace panoscan::app;

namespace {

void add_sim_options(CLI::App* cmd, SimArguments& a, bool with_scene) {
  if (with_scene) {
    cmd->add_option("--scene", a.scene, "built-in scene name (living_room, office) or a mesh file (OBJ/PLY/glTF)")
        ->capture_default_str();
    cmd->add_option("--position", a.position, "scanning position: 1-based index or name (e.g. SO-2)")
        ->capture_default_str();
  }
  cmd->add_option("--config", a.config_file, "YAML/JSON config file (keys: see README)");
  cmd->add_option("--set", a.overrides,
                  "override a config key, e.g. --set noise.preset=kinect or --set scene.texture=rich (repeatable)");
  cmd->add_option("--resolution", a.resolution, "image size WIDTHxHEIGHT, e.g. 640x480");
  cmd->add_option("--frames", a.frames, "frames per camera after --every (0 = the whole turn)");
  cmd->add_option("--seed", a.seed, "random seed");
  cmd->add_option("--noise", a.noise, "depth noise preset: handa, handa-icl, kinect, none (off)");
  cmd->add_option("--every", a.every, "render every n-th frame of each camera (timestamps kept)");
  cmd->add_option("--threads", a.threads, "worker threads (0 = all cores)");
  cmd->add_flag("--clean-depth", a.clean_depth, "also write noiseless depth to groundtruth/depth_clean");
  cmd->add_flag("--normals", a.normals, "also write camera-frame normals to groundtruth/normals (EXR)");
  cmd->add_flag("--ids", a.ids, "also write triangle and material ids to groundtruth/ids (32-bit EXR)");
  cmd->add_flag("--overwrite", a.overwrite, "replace an existing output directory");
}

}  // namespace

int main(int argc, char** argv) {
  set_up_process(argv);  // core/process.h: OpenMP's wait policy, the heap's huge pages, the allocator
  CLI::App app{"PanoScan: panoramic RGB-D scanning testbed (Yang et al., TOG 2020)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "panoscan " + project_version() + " (" + source_revision() + ")");
  bool verbose = false, quiet = false;
  app.add_flag("-v,--verbose", verbose, "debug logging");
  app.add_flag("-q,--quiet", quiet, "warnings and errors only");

  // scene list | export
  CLI::App* scene_cmd = app.add_subcommand("scene", "scenes: list or export the built-in ones, generate seeded rooms");
  scene_cmd->require_subcommand(1);
  CLI::App* scene_list = scene_cmd->add_subcommand("list", "list built-in scenes and their scanning positions");
  CLI::App* scene_export =
      scene_cmd->add_subcommand("export", "write a scene as OBJ+MTL+PNG, ground-truth PLY, positions");
  SceneExportArguments export_args;
  scene_export->add_option("--scene", export_args.scene, "built-in scene name or a mesh file")->required();
  scene_export->add_option("--out", export_args.out, "output directory")->required();
  scene_export->add_option("--config", export_args.config_file, "YAML/JSON config file (key: scene.texture)");
  scene_export->add_option("--set", export_args.overrides,
                           "built-in scenes' texture density: --set scene.texture=icl|rich|plain (default icl)");

  SceneGenerateArguments generate_args;
  CLI::App* scene_generate = scene_cmd->add_subcommand(
      "generate", "generate a seeded room (rectangular or L-shaped, furnished, 2-6 scanning positions) and export it");
  scene_generate->add_option("--kind", generate_args.kind, "office or living_room")->required();
  scene_generate->add_option("--seed", generate_args.seed, "the room's seed (same seed, same files)")->required();
  scene_generate->add_option("--texture", generate_args.texture, "texture density: icl (default), rich or plain");
  scene_generate->add_option("--out", generate_args.out, "output directory")->required();
  scene_generate->add_option("--config", generate_args.config_file, "YAML/JSON config file (key: scene.texture)");
  scene_generate->add_option("--set", generate_args.overrides, "--set scene.texture=icl|rich|plain");

  // sim
  SimArguments sim_args;
  CLI::App* sim_cmd = app.add_subcommand("sim", "simulate one scanning position and write the scan with ground truth");
  add_sim_options(sim_cmd, sim_args, true);
  sim_cmd->add_option("--out", sim_args.out, "output scan directory")->required();

  // import tum
  CLI::App* import_cmd = app.add_subcommand("import", "bring your own data: recordings into a scan folder");
  import_cmd->require_subcommand(1);
  ImportTumArguments import_tum_args;
  CLI::App* import_tum = import_cmd->add_subcommand(
      "tum", "TUM RGB-D sequences (rgb.txt, depth.txt, groundtruth.txt), one per sensor, into a scan folder");
  import_tum->add_option("--input", import_tum_args.inputs, "TUM sequence folder(s); sensor K = the K-th")
      ->required()
      ->expected(1, -1);
  import_tum->add_option("--out", import_tum_args.out, "output scan folder")->required();
  import_tum->add_option("--intrinsics", import_tum_args.intrinsics,
                         "fx,fy,cx,cy in pixels (once for all inputs, or once per input)");
  import_tum->add_option("--camera", import_tum_args.cameras,
                         "intrinsics preset fr1, fr2, fr3 or ros (default: from the folder name rgbd_dataset_freiburgN_*)");
  import_tum->add_option("--extrinsics", import_tum_args.extrinsics,
                         "JSON {\"ref_from_cam\": [one 4x4 matrix per input]} (required for several inputs)");
  import_tum->add_option("--depth-scale", import_tum_args.depth_scale, "depth PNG units per metre")
      ->capture_default_str();
  import_tum->add_option("--max-dt", import_tum_args.max_dt,
                         "seconds: colour-depth association and ground-truth interpolation window")
      ->capture_default_str();
  import_tum->add_option("--motion", import_tum_args.motion, "rig.json motion: handheld or rotator")
      ->capture_default_str();
  import_tum->add_flag("--hard-link", import_tum_args.hard_link, "hard-link the images instead of copying them");
  import_tum->add_flag("--overwrite", import_tum_args.overwrite, "replace an existing output folder");

  // export
  CLI::App* export_cmd = app.add_subcommand("export", "scans out to outside systems (TUM, COLMAP, nerfstudio)");
  export_cmd->require_subcommand(1);
  ExportPrestitchedArguments prestitched_args;
  CLI::App* export_prestitched = export_cmd->add_subcommand(
      "prestitched", "the paper's pre-stitched frames (Table 1's outside systems) as a TUM RGB-D sequence");
  export_prestitched->add_option("--scan", prestitched_args.scan, "scan directory")->required();
  export_prestitched->add_option("--stitch", prestitched_args.stitch,
                                 "ex: calibrated extrinsics, gt: true relative poses (simulated scans)")
      ->capture_default_str();
  export_prestitched->add_option("--out", prestitched_args.out, "output TUM sequence folder")->required();
  export_prestitched->add_option("--width", prestitched_args.width, "stitched width (0 = the reference camera's)");
  export_prestitched->add_option("--height", prestitched_args.height, "stitched height (0 = twice the width)");
  export_prestitched->add_option("--threads", prestitched_args.threads, "worker threads (0 = all cores)");
  export_prestitched->add_flag("--overwrite", prestitched_args.overwrite, "replace an existing output folder");
  ExportModelArguments colmap_args, nerfstudio_args;
  auto add_model_options = [](CLI::App* cmd, ExportModelArguments& args) {
    cmd->add_option("--scan", args.scan, "scan directory");
    cmd->add_option("--poses", args.poses, "ground-truth, tracked, or a folder from recon track")->capture_default_str();
    cmd->add_option("--out", args.out, "output folder")->required();
    cmd->add_option("--config", args.config_file, "YAML/JSON config (keys track.*, frontend.* for --poses tracked)");
    cmd->add_option("--set", args.overrides, "override a config key (repeatable)");
    cmd->add_option("--threads", args.threads, "worker threads (0 = all cores)");
    cmd->add_flag("--overwrite", args.overwrite, "replace an existing output folder");
  };
  CLI::App* export_colmap = export_cmd->add_subcommand(
      "colmap", "a COLMAP text model (cameras.txt, images.txt, points3D.txt) with the images");
  add_model_options(export_colmap, colmap_args);
  export_colmap->add_option("--panoramas", colmap_args.panoramas,
                            "panorama folders instead of --scan: each as six cube faces, posed by its stored pose");
  export_colmap->add_option("--points-per-image", colmap_args.points_per_image,
                            "3D points back-projected from each image's depth (0 = none)")
      ->capture_default_str();
  CLI::App* export_nerfstudio =
      export_cmd->add_subcommand("nerfstudio", "nerfstudio's transforms.json with the images and depth");
  add_model_options(export_nerfstudio, nerfstudio_args);

  // demo
  DemoArguments demo_args;
  CLI::App* demo_cmd =
      app.add_subcommand("demo", "the main job: simulate office SO-1 and SO-3, reconstruct them, print the RMSE table");
  demo_cmd->add_option("--out", demo_args.out, "output folder (replaced)")->capture_default_str();
  demo_cmd->add_option("--threads", demo_args.threads, "worker threads (0 = all cores)");

  // report
  ReportArguments report_args;
  CLI::App* report_cmd = app.add_subcommand(
      "report", "one self-contained HTML page of result folders: tables beside the paper's, previews, plots");
  report_cmd
      ->add_option("--results", report_args.results,
                   "result folders: table records, panoramas, track folders, scans, demo or scene folders, or "
                   "folders of them (searched 5 levels down); also eval --json files")
      ->required()
      ->expected(1, -1);
  report_cmd->add_option("--out", report_args.out, "output HTML file (written atomically)")->capture_default_str();
  report_cmd->add_option("--title", report_args.title, "the page's title");

  // tables
  TablesArguments tables_args;
  CLI::App* tables_cmd = app.add_subcommand(
      "tables", "regenerate the paper's tables and figures (one command each; `tables list` names them)");
  tables_cmd->add_option("names", tables_args.names,
                         "table1 ... table6, fig8, all, or list; `merge RECORD...` merges runs (--out); `scan "
                         "LABEL...` simulates scans into the cache; `columns NAME` lists a table's columns and "
                         "their scans")
      ->required();
  tables_cmd->add_option("--size", tables_args.size, "quick (CI size) or full (the record)")->capture_default_str();
  tables_cmd->add_option("--noise", tables_args.noise, "handa (the paper's), kinect, or both")->capture_default_str();
  tables_cmd->add_option("--out", tables_args.out, "results folder: <out>/<noise>/<table>/")->capture_default_str();
  tables_cmd->add_option("--cache", tables_args.cache, "simulated scans, reused across runs (default <out>/scans)");
  tables_cmd->add_option("--only", tables_args.only, "restrict to these scan or pair labels (repeatable)");
  tables_cmd->add_option("--seed", tables_args.seed, "simulation seed")->capture_default_str();
  tables_cmd->add_option("--seeds", tables_args.seeds,
                         "one run per seed (e.g. 1-8 or 1,3,5-7), then mean, 95% CI and n per cell and each claim's "
                         "paired difference");
  tables_cmd->add_option("--scenes", tables_args.scenes,
                         "rooms measured: builtin, generated:N (the generator's rooms 1..N) or scene files "
                         "(repeatable; default builtin)");
  tables_cmd->add_option("--threads", tables_args.threads, "worker threads (0 = all cores)");
  tables_cmd->add_flag("--record-refusals", tables_args.record_refusals,
                       "when a stage refuses its result (e.g. tracking fails its self-check), write the refusal as "
                       "the run's record (no cells) instead of stopping with exit 2; for one column per run (--only), "
                       "as the workflow runs it");
  tables_cmd->add_option("--set", tables_args.overrides,
                         "the scanned rooms' texture density: --set scene.texture=icl|rich|plain (default icl)");

  // eval cloud | traj
  CLI::App* eval_cmd = app.add_subcommand("eval", "evaluate against ground truth: clouds against meshes, trajectories");
  eval_cmd->require_subcommand(1);
  EvalCloudArguments cloud_args;
  CLI::App* eval_cloud =
      eval_cmd->add_subcommand("cloud", "exact distances of a point cloud (PLY) to the ground-truth mesh");
  eval_cloud->add_option("--cloud", cloud_args.cloud, "reconstructed cloud (PLY; a mesh's vertices also work)")
      ->required();
  eval_cloud->add_option("--mesh", cloud_args.mesh, "ground-truth mesh (PLY)");
  eval_cloud->add_option("--scan", cloud_args.scan,
                         "a simulated scan: mesh from groundtruth/mesh.ply, viewpoints from groundtruth/cam*.txt");
  eval_cloud->add_option("--viewpoints-from", cloud_args.viewpoints_from,
                         "TUM trajectory whose mean centre is a viewpoint for completeness (repeatable)");
  eval_cloud->add_option("--transform", cloud_args.transform,
                         "scene_from_cloud applied first: a 4x4 .txt or a pose JSON (e.g. an export's "
                         "scene_from_sequence.txt)");
  eval_cloud->add_option("--coloured-ply", cloud_args.coloured_ply, "write the cloud coloured by its error");
  eval_cloud->add_option("--json", cloud_args.json, "write every figure and the settings as JSON");
  eval_cloud->add_option("--config", cloud_args.config_file, "YAML/JSON config (keys: see README)");
  eval_cloud->add_option("--set", cloud_args.overrides, "override a config key (repeatable)");
  eval_cloud->add_option("--threads", cloud_args.threads, "worker threads (0 = all cores)");
  EvalFlatArguments flat_args;
  CLI::App* eval_flat = eval_cmd->add_subcommand(
      "flat-pixels", "texture density: share of valid pixels in flat regions (grey-level std below a threshold)");
  eval_flat->add_option("--panorama", flat_args.panorama, "a panorama folder (recon panorama); valid = has depth");
  eval_flat->add_option("--image", flat_args.image, "an image file (PNG/JPEG); every pixel valid");
  eval_flat->add_option("--window", flat_args.window, "window size (odd)")->capture_default_str();
  eval_flat->add_option("--threshold", flat_args.threshold, "grey-level std threshold (0..255 scale)")
      ->capture_default_str();
  eval_flat->add_option("--json", flat_args.json, "write the figures as JSON");
  EvalTrajArguments traj_args;
  CLI::App* eval_traj = eval_cmd->add_subcommand("traj", "ATE and RPE of an estimated TUM trajectory");
  eval_traj->add_option("--gt", traj_args.gt, "ground-truth TUM trajectory")->required();
  eval_traj->add_option("--est", traj_args.est, "estimated TUM trajectory")->required();
  eval_traj->add_option("--json", traj_args.json, "write every figure and the settings as JSON");
  eval_traj->add_option("--config", traj_args.config_file, "YAML/JSON config (keys: see README)");
  eval_traj->add_option("--set", traj_args.overrides, "override a config key (repeatable)");

  // recon track
  CLI::App* recon_cmd = app.add_subcommand("recon", "reconstruction: track, panorama, register, integrate, scene");
  recon_cmd->require_subcommand(1);
  ReconTrackArguments track_args;
  CLI::App* recon_track =
      recon_cmd->add_subcommand("track", "joint tracking of the unsynchronized cameras (paper 4.1)");
  recon_track->add_option("--scan", track_args.scan, "scan directory")->required();
  recon_track->add_option("--out", track_args.out, "output folder: camK.txt, rig_estimate.json, tracking_stats.json")
      ->required();
  recon_track->add_option("--mode", track_args.mode, "full (default), ba-only, single-camera, fixed-extrinsics");
  recon_track->add_option("--config", track_args.config_file, "YAML/JSON config (keys track.*, frontend.*)");
  recon_track->add_option("--set", track_args.overrides, "override a config key (repeatable)");
  recon_track->add_option("--threads", track_args.threads, "worker threads (0 = all cores)");
  recon_track->add_flag("--overwrite", track_args.overwrite, "replace existing outputs");
  recon_track->add_flag("--allow-unreliable", track_args.allow_unreliable,
                        "write a trajectory that fails its self-check (marked unreliable) instead of refusing");

  ReconPanoramaArguments pano_args;
  CLI::App* recon_pano = recon_cmd->add_subcommand("panorama", "build one RGB-D panorama with uncertainty (paper 4.2)");
  recon_pano->add_option("--scan", pano_args.scan, "scan directory")->required();
  recon_pano->add_option("--poses", pano_args.poses, "ground-truth, tracked, or a folder from recon track")
      ->capture_default_str();
  recon_pano->add_option("--out", pano_args.out, "output panorama folder")->required();
  recon_pano->add_option("--method", pano_args.method, "ave, tv, tv-radial, tsa (default), tp");
  recon_pano->add_option("--height", pano_args.height, "panorama height H (width 2H)");
  recon_pano->add_option("--config", pano_args.config_file, "YAML/JSON config (keys panorama.*, track.*)");
  recon_pano->add_option("--set", pano_args.overrides, "override a config key (repeatable)");
  recon_pano->add_option("--threads", pano_args.threads, "worker threads (0 = all cores)");
  recon_pano->add_flag("--overwrite", pano_args.overwrite, "replace existing outputs");

  ReconSceneArguments scene_args;
  CLI::App* recon_scene = recon_cmd->add_subcommand(
      "scene", "the whole method: panoramas of several scans, registration, integration into one cloud");
  recon_scene->add_option("--scans", scene_args.scans, "scan directories, neighbours next to each other")->required();
  recon_scene->add_option("--poses", scene_args.poses, "tracked (default) or ground-truth")->capture_default_str();
  recon_scene->add_option("--out", scene_args.out, "output folder: cloud.ply, panoramas, poses")->required();
  recon_scene->add_option("--config", scene_args.config_file, "YAML/JSON config (keys: see README)");
  recon_scene->add_option("--set", scene_args.overrides, "override a config key (repeatable)");
  recon_scene->add_option("--threads", scene_args.threads, "worker threads (0 = all cores)");
  recon_scene->add_flag("--align-to-ground-truth", scene_args.align_to_ground_truth,
                        "simulated scans: write the cloud in the scene frame (for eval)");
  recon_scene->add_flag("--overwrite", scene_args.overwrite, "replace existing outputs");

  ReconRegisterArguments register_args;
  CLI::App* recon_register = recon_cmd->add_subcommand(
      "register",
      "register two panoramas (ORB + RANSAC guess, then GICP with the measured variance, paper 5.1) or two point "
      "clouds (.ply / .pcd: GICP from the identity or --initial, with the files' per-point covariance)");
  recon_register
      ->add_option("--source", register_args.source,
                   "panorama folder (from recon panorama) or point-cloud file (.ply, .pcd) to move")
      ->required();
  recon_register->add_option("--target", register_args.target, "panorama folder or point-cloud file it is registered to")
      ->required();
  recon_register->add_option("--method", register_args.method,
                             "gicp-ours (default), gicp-def, gicp, anisotropic, p2plane-curv, p2plane, p2point");
  recon_register->add_option("--initial", register_args.initial,
                             "initial target_from_source (pose JSON, a recon register output, or a 4x4 matrix .txt) "
                             "instead of ORB (panoramas) or the identity (clouds)");
  recon_register->add_option("--matrix", register_args.matrix,
                             "output 4x4 text matrix of target_from_source (default: --out with .txt for .json)");
  recon_register->add_option("--voxel", register_args.voxel_m,
                             "clouds: average the points in voxels of this size (m) first (registration.voxel_m)");
  recon_register->add_option("--out", register_args.out, "output JSON: target_from_source and diagnostics")->required();
  recon_register->add_option("--config", register_args.config_file, "YAML/JSON config (keys registration.*)");
  recon_register->add_option("--set", register_args.overrides, "override a config key (repeatable)");
  recon_register->add_option("--threads", register_args.threads, "worker threads (0 = all cores)");
  recon_register->add_flag("--overwrite", register_args.overwrite, "replace an existing output");

  ReconIntegrateArguments integrate_args;
  CLI::App* recon_integrate = recon_cmd->add_subcommand(
      "integrate", "merge registered panoramas into one cloud: align, average or MAP (paper 5.2)");
  recon_integrate->add_option("--panoramas", integrate_args.panoramas, "panorama folders; the first fixes the frame")
      ->required();
  recon_integrate->add_option("--poses", integrate_args.poses,
                              "recon register outputs linking them (pose graph if redundant), or 'stored'");
  recon_integrate->add_option("--method", integrate_args.method, "map (default), average, align");
  recon_integrate->add_option("--out", integrate_args.out, "output cloud (PLY with colour and variance)")->required();
  recon_integrate->add_option("--placement-out", integrate_args.placement_out,
                              "also write the panoramas' poses and which registrations were used (JSON)");
  recon_integrate->add_option("--config", integrate_args.config_file,
                              "YAML/JSON config (keys integration.*, registration.*)");
  recon_integrate->add_option("--set", integrate_args.overrides, "override a config key (repeatable)");
  recon_integrate->add_option("--threads", integrate_args.threads, "worker threads (0 = all cores)");
  recon_integrate->add_flag("--overwrite", integrate_args.overwrite, "replace an existing output");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (verbose) set_log_level(LogLevel::kDebug);
  if (quiet) set_log_level(LogLevel::kWarn);
  const auto environment = [](const char* name) { return std::getenv(name) ? std::getenv(name) : "(unset)"; };
  log_debug(fmt::format("process settings (core/process.h): OMP_WAIT_POLICY={} GLIBC_TUNABLES={}",
                        environment("OMP_WAIT_POLICY"), environment("GLIBC_TUNABLES")));

  try {
    // Read before any kernel asks, so that a bad value is reported as such rather than mid-stage.
    const cpu::Isa isa = cpu::dispatched_isa();
    const std::string embree_config = cpu::embree_device_config();
    log_debug(fmt::format("kernels (core/cpu_features.h): PANOSCAN_CPU={}, dispatching up to {}; Embree's device: '{}'",
                          environment("PANOSCAN_CPU"), cpu::isa_name(isa), embree_config));
    if (*scene_list) {
      run_scene_list();
    } else if (*scene_export) {
      run_scene_export(export_args);
    } else if (*scene_generate) {
      run_scene_generate(generate_args);
    } else if (*sim_cmd) {
      run_sim(sim_args, {});
    } else if (*eval_cloud) {
      run_eval_cloud(cloud_args);
    } else if (*eval_flat) {
      run_eval_flat(flat_args);
    } else if (*eval_traj) {
      run_eval_traj(traj_args);
    } else if (*recon_track) {
      run_recon_track(track_args);
    } else if (*recon_pano) {
      run_recon_panorama(pano_args);
    } else if (*recon_scene) {
      run_recon_scene(scene_args);
    } else if (*recon_register) {
      run_recon_register(register_args);
    } else if (*recon_integrate) {
      run_recon_integrate(integrate_args);
    } else if (*import_tum) {
      run_import_tum(import_tum_args);
    } else if (*export_prestitched) {
      run_export_prestitched(prestitched_args);
    } else if (*export_colmap) {
      run_export_colmap(colmap_args);
    } else if (*export_nerfstudio) {
      run_export_nerfstudio(nerfstudio_args);
    } else if (*tables_cmd) {
      run_tables(tables_args);
    } else if (*demo_cmd) {
      run_demo(demo_args);
    } else if (*report_cmd) {
      run_report(report_args);
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
