// `panoscan export prestitched|colmap|nerfstudio`: reading the arguments, choosing the poses,
// calling the export library (export/exports.h), reporting.
#include <iostream>

#include <fmt/format.h>

#include "command_support.h"
#include "commands.h"
#include "panoscan/core/error.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/export/exports.h"

namespace panoscan::app {

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
  return scan_trajectory(a.poses, a.scan, scan, tracking);
}

}  // namespace

void run_export_colmap(const ExportModelArguments& a) {
  const ScanIndex scan = read_scan_index(a.scan);
  ColmapExportOptions options;
  options.points_per_image = a.points_per_image;
  options.check("--points-per-image");
  const RigTrajectory poses = export_poses(a, scan);
  const ColmapExportReport report = export_colmap(scan, poses, a.out, options, a.overwrite);
  std::cout << fmt::format(
      "COLMAP text model ({} poses): {} cameras, {} images, {} points with {} observations; wrote {} (cameras.txt, "
      "images.txt, points3D.txt, images/)\n",
      poses.source, report.cameras, report.images, report.points, report.observations, a.out);
}

void run_export_nerfstudio(const ExportModelArguments& a) {
  const ScanIndex scan = read_scan_index(a.scan);
  const RigTrajectory poses = export_poses(a, scan);
  const NerfstudioExportReport report = export_nerfstudio(scan, poses, a.out, a.overwrite);
  std::cout << fmt::format("nerfstudio transforms.json ({} poses): {} frames with depth; wrote {}\n", poses.source,
                           report.frames, a.out);
}

}  // namespace panoscan::app
