// `panoscan export prestitched|colmap|nerfstudio`: reading the arguments, choosing the poses,
// calling the export library (export/exports.h), reporting.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "command_support.h"
#include "commands.h"
#include "panoscan/core/error.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/export/exports.h"
#include "panoscan/recon/poses.h"
#include "panoscan/recon/panorama.h"

namespace panoscan::app {

namespace fs = std::filesystem;

void run_export_prestitched(const ExportPrestitchedArguments& a) {
  if (a.stitch != "ex" && a.stitch != "gt")
    throw make_error("--stitch", "", "expected ex (calibrated extrinsics) or gt (true relative poses), got '" +
                                         a.stitch + "'");
  const ScanIndex scan = read_scan_index(a.scan);
  StitchOptions options;
  options.width = a.width;
  options.height = a.height;
  if (a.threads >= 0) options.threads = a.threads;
  options.check("--width/--height");
  RigTrajectory truth;
  if (a.stitch == "gt") truth = eval::groundtruth_rig_trajectory(a.scan);
  const PrestitchedExportReport report =
      export_prestitched(scan, a.out, options, a.stitch == "gt" ? &truth : nullptr, a.stitch, a.overwrite);
  const PinholeIntrinsics& k = report.intrinsics;
  std::cout << fmt::format(
      "pre-stitched ({}) TUM sequence: {} frames {}x{} (fx {:.2f}, fy {:.2f}, cx {:.2f}, cy {:.2f}), {} camera frames "
      "left out, ground truth for {} frames; wrote {} (rgb.txt, depth.txt, groundtruth.txt, calibration.txt, "
      "orbslam2.yaml)\n",
      a.stitch, report.frames, k.width, k.height, k.fx, k.fy, k.cx, k.cy, report.missing_camera_frames,
      report.groundtruth_poses, a.out);
}

namespace {

RigTrajectory export_poses(const ExportModelArguments& a, const ScanIndex& scan) {
  Config config = load_config(a.config_file, a.overrides);
  if (a.threads >= 0) config.set("threads", std::to_string(a.threads));
  const TrackingOptions tracking = tracking_options_from_config(config);
  config.check_all_used();
  return scan_poses(a.poses, a.scan, scan, tracking);
}

}  // namespace

void run_export_colmap(const ExportModelArguments& a) {
  if (a.scan.empty() == a.panoramas.empty())
    throw make_error("--scan", "", "give exactly one of --scan (a scan folder) or --panoramas (panorama folders)");
  ColmapExportOptions options;
  options.points_per_image = a.points_per_image;
  options.check("--points-per-image");
  if (!a.panoramas.empty()) {
    if (a.poses != "ground-truth" || !a.config_file.empty() || !a.overrides.empty())
      throw make_error("--poses", "", "panoramas carry their own pose (panorama.json world_from_pano); no --poses");
    std::vector<Panorama> panoramas;
    panoramas.reserve(a.panoramas.size());
    std::vector<ColmapPanorama> inputs;
    for (std::size_t k = 0; k < a.panoramas.size(); ++k) {
      panoramas.push_back(read_panorama(a.panoramas[k]));
      // Folder names as image folders; numbered when two panoramas share one.
      std::string name = fs::path(a.panoramas[k]).lexically_normal().filename().string();
      if (name.empty()) name = fs::path(a.panoramas[k]).lexically_normal().parent_path().filename().string();
      for (const ColmapPanorama& other : inputs)
        if (other.name == name) name = fmt::format("{:02d}-{}", k, name);
      inputs.push_back({name, nullptr});
    }
    for (std::size_t k = 0; k < inputs.size(); ++k) inputs[k].panorama = &panoramas[k];
    const ColmapExportReport report = export_colmap_panoramas(inputs, a.out, options, a.overwrite);
    std::cout << fmt::format(
        "COLMAP text model of {} panoramas as cube faces: {} images, {} points with {} observations; wrote {}\n",
        inputs.size(), report.images, report.points, report.observations, a.out);
    return;
  }
  const ScanIndex scan = read_scan_index(a.scan);
  const RigTrajectory poses = export_poses(a, scan);
  const ColmapExportReport report = export_colmap(scan, poses, a.out, options, a.overwrite);
  std::cout << fmt::format(
      "COLMAP text model ({} poses): {} cameras, {} images, {} points with {} observations; wrote {} (cameras.txt, "
      "images.txt, points3D.txt, images/)\n",
      poses.source, report.cameras, report.images, report.points, report.observations, a.out);
}

void run_export_nerfstudio(const ExportModelArguments& a) {
  if (a.scan.empty()) throw make_error("--scan", "", "a scan folder is required");
  const ScanIndex scan = read_scan_index(a.scan);
  const RigTrajectory poses = export_poses(a, scan);
  const NerfstudioExportReport report = export_nerfstudio(scan, poses, a.out, a.overwrite);
  std::cout << fmt::format("nerfstudio transforms.json ({} poses): {} frames with depth; wrote {}\n", poses.source,
                           report.frames, a.out);
}

}  // namespace panoscan::app
