// Shared parts of the stage-2 drivers (table4.cpp, table5.cpp); see stage2_common.h.
#include "stage2_common.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>

#include "cache_lock.h"
#include "drivers.h"
#include "scene_catalog.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/scan.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"

namespace fs = std::filesystem;

namespace panoscan::tables::stage2 {

namespace {

Panorama cached_panorama(const std::string& label, const TablesOptions& options, bool tracked) {
  const SizePreset preset = size_preset(options.size);
  const fs::path scan_dir = cached_scan(label, options);
  const fs::path cache = (options.cache.empty() ? options.out / "scans" : options.cache) / "panoramas";
  fs::create_directories(cache);
  // The scan's key (its folder name) names the scan; the rest names what changes the panorama.
  const std::string key =
      fmt::format("{}_{}_tsa_H{}", scan_dir.filename().string(), tracked ? "tracked" : "gt", preset.panorama_height);
  const fs::path dir = cache / key;
  CacheLock lock(cache / (key + ".lock"));
  if (fs::exists(dir / "panorama.json")) return read_panorama(dir);
  Config config;
  config.set("panorama.height", std::to_string(preset.panorama_height));
  config.set("panorama.method", "tsa");
  if (options.threads > 0) config.set("threads", std::to_string(options.threads));
  use_papers_tracking_graph(config);
  const PanoramaOptions panorama_options = panorama_options_from_config(config);
  const TrackingOptions tracking_options = tracking_options_from_config(config);
  config.check_all_used();
  log_info(fmt::format("tables: building the {}-pose panorama of {} into {}", tracked ? "tracked" : "ground-truth",
                       label, dir.string()));
  const ScanIndex scan = read_scan_index(scan_dir);
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan_dir);
  RigTrajectory trajectory = truth;
  if (tracked) {
    TrackingResult result = track_scan(scan, tracking_options);
    require_reliable_tracking(result, tracking_options, label);
    trajectory = std::move(result.trajectory);
  }
  Panorama panorama = build_panorama(scan, trajectory, panorama_options).panorama;
  if (tracked) {
    const int reference = scan.rig.reference_sensor;
    panorama.world_from_pano =
        eval::scene_from_reconstruction(truth.world_from_cam[reference], trajectory.world_from_cam[reference]) *
        panorama.world_from_pano;
  }
  write_panorama(dir, panorama, false);
  return panorama;
}

}  // namespace

Panorama ground_truth_panorama(const std::string& label, const TablesOptions& options) {
  return cached_panorama(label, options, false);
}

Panorama tracked_panorama(const std::string& label, const TablesOptions& options) {
  return cached_panorama(label, options, true);
}

std::unique_ptr<eval::MeshDistance> scene_mesh(const std::string& label, const TablesOptions& options) {
  const LabelledScene scene = scene_for_label(label, options);
  return std::make_unique<eval::MeshDistance>(scene.scene->mesh, scene.scene->name);
}

int registration_stride(int panorama_height) { return std::max(1, panorama_height / 256); }

PairRegistrationOptions registration_options(const TablesOptions& options) {
  Config config;  // the defaults, through the same path as `recon register`
  PairRegistrationOptions r = pair_registration_options_from_config(config);
  r.cloud.pixel_stride = registration_stride(size_preset(options.size).panorama_height);
  r.icp.threads = options.threads;
  r.cloud.surface.threads = options.threads;
  r.features.seed = options.seed;
  return r;
}

PanoramaCloudOptions integration_cloud_options(const TablesOptions& options) {
  PanoramaCloudOptions cloud = registration_options(options).cloud;
  cloud.pixel_stride = 1;
  return cloud;
}

DistanceStats distance_stats(std::vector<double> d) {
  DistanceStats s;
  if (d.empty()) return s;
  const eval::ErrorStats stats = eval::summarize_errors(std::move(d));
  s.rmse_mm = stats.rmse * 1e3;
  s.mean_mm = stats.mean * 1e3;
  s.median_mm = stats.median * 1e3;
  return s;
}

}  // namespace panoscan::tables::stage2
