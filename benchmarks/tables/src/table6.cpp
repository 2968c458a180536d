// Table 6 of the paper: time per module. For each pair of the size preset (quick: SO-13), both
// scans are tracked (front end + factor graph), fused into TSA panoramas from the tracked poses,
// registered (ORB guess + GICP with the measured variance) and integrated (MAP), each stage timed
// on its own with the options' thread count. Columns follow the paper's: per frame (ms) the front
// end and the warping ("Rendering", §4.2); per panorama (s) tracking and optimisation; per pair (s)
// alignment and integration.
#include <chrono>

#include <fmt/format.h>

#include "drivers.h"
#include "panoscan/core/timer.h"
#include "panoscan/core/config.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/scene.h"

namespace panoscan::tables {

namespace {

TableRun run_table6(const TablesOptions& options) {
  const SizePreset preset = size_preset(options.size);
  Config config;
  config.set("panorama.height", std::to_string(preset.panorama_height));
  config.set("threads", std::to_string(options.threads));
  use_papers_tracking_graph(config);
  const SceneOptions scene_options = scene_options_from_config(config);

  eval::ResultTable table;
  table.title =
      fmt::format("Table 6: time per module ({} size, {} threads; per frame in ms, per panorama and per pair in s)",
                  preset.name, options.threads > 0 ? std::to_string(options.threads) : "all");
  table.unit = "ms | s";
  table.decimals = 2;
  TableRun run;
  for (const std::string& pair : pair_labels(options)) {
    const auto [source_label, target_label] = pair_scans(pair);
    std::vector<Panorama> panoramas;
    double frontend_ms = 0, warp_ms = 0, tracking_s = 0, optimise_s = 0;
    for (const std::string& label : {target_label, source_label}) {
      const ScanIndex scan = read_scan_index(cached_scan(label, options));
      TrackingResult tracked = track_scan(scan, scene_options.tracking);
      require_reliable_tracking(tracked, scene_options.tracking, label);
      const int frames = tracked.stats.frames;
      frontend_ms += tracked.stats.frontend_seconds * 1e3 / std::max(frames, 1);
      tracking_s += tracked.stats.init_seconds + tracked.stats.solve_seconds;
      PanoramaResult built = build_panorama(scan, tracked.trajectory, scene_options.panorama);
      warp_ms += built.warp_seconds * 1e3 / std::max<std::size_t>(built.frames_used, 1);
      optimise_s += built.fusion_seconds;
      panoramas.push_back(std::move(built.panorama));
    }
    const std::string row = "Ours (" + pair + ")";
    table.set(row, "Landmarks, per frame (ms)", frontend_ms / 2);
    table.set(row, "Rendering, per frame (ms)", warp_ms / 2);
    table.set(row, "Tracking, per panorama (s)", tracking_s / 2);
    table.set(row, "Optimize, per panorama (s)", optimise_s / 2);

    auto start = std::chrono::steady_clock::now();
    const PairRegistration registration = register_panorama_pair(panoramas[1], panoramas[0], scene_options.registration,
                                                                 nullptr, source_label, target_label);
    table.set(row, "Align, per pair (s)", seconds_since(start));

    start = std::chrono::steady_clock::now();
    std::vector<PanoramaPoints> points;
    points.push_back(panorama_integration_points(panoramas[0], Rigid3d::Identity(), scene_options.registration.cloud));
    points.push_back(
        panorama_integration_points(panoramas[1], registration.target_from_source, scene_options.registration.cloud));
    const IntegrationResult merged = integrate_panoramas(points, scene_options.integration);
    table.set(row, "Integrate, per pair (s)", seconds_since(start));
    run.notes.push_back(fmt::format("{}: {} + {} points merged into {} ({} groups)", pair, points[0].points.size(),
                                    points[1].points.size(), merged.cloud.size(), merged.groups));
  }
  run.tables.push_back(table);
  run.notes.push_back(
      "Paper (6-core CPU, 640x480, n = 16, PCL's single-thread GICP): landmarks 4.3 ms, rendering 57.3 ms per frame; "
      "tracking 3.02 s, optimize 13.94 s per panorama; align 35.92 s, integrate 2.63 s per pair.");
  run.settings_json =
      fmt::format(R"({{"panorama_method": "{}", "registration_method": "{}", "integration": "{}"}})",
                  to_string(scene_options.panorama.fusion.method), to_string(scene_options.registration.icp.method),
                  to_string(scene_options.integration.method));
  return run;
}

}  // namespace

TableDriver table6_driver() {
  return {"table6", "time per module (front end, warping, tracking, optimisation, alignment, integration)", run_table6,
          pair_columns};
}

}  // namespace panoscan::tables
