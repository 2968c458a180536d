// The one-call entry of stage 1b (`panoscan recon panorama`) and its options.
#include <chrono>
#include <sstream>

#include <tbb/task_arena.h>

#include "panoscan/core/timer.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/panorama.h"

namespace panoscan {

void PanoramaOptions::check(const std::string& origin) const {
  warp.check(origin);
  fusion.check(origin);
  if (threads < 0) throw make_error(origin, "threads", "must be >= 0 (0 = all cores)");
}

PanoramaOptions panorama_options_from_config(Config& config) {
  PanoramaOptions o;
  o.warp.height = config.get_int("panorama.height", o.warp.height, 4, 16384);
  o.warp.max_edge_depth_jump_m = config.get_double("panorama.lambda_a_m", o.warp.max_edge_depth_jump_m, 1e-4, 10.0);
  o.warp.min_depth_m = config.get_double("panorama.min_depth_m", o.warp.min_depth_m, 0.0, 100.0);
  o.warp.max_depth_m = config.get_double("panorama.max_depth_m", o.warp.max_depth_m, 0.0, 100.0);
  o.warp.frame_stride = config.get_int("panorama.frame_stride", o.warp.frame_stride, 1, 100000);
  o.warp.min_valid_depth_share =
      config.get_double("panorama.min_valid_depth_share", o.warp.min_valid_depth_share, 0.0, 1.0);
  o.fusion.method = depth_fusion_method_from_string(
      config.get_string("panorama.method", to_string(o.fusion.method),
                        {"ave", "average", "tv", "tv-l1", "tv-radial", "tsa", "tsa-l1", "tp", "tp-l1"}),
      config.origin());
  o.fusion.lambda = config.get_double("panorama.lambda", o.fusion.lambda, -1.0, 1e15);
  o.fusion.lambda_reference_height =
      config.get_int("panorama.lambda_reference_height", o.fusion.lambda_reference_height, 1, 1 << 20);
  o.fusion.lambda_reference_count =
      config.get_double("panorama.lambda_reference_count", o.fusion.lambda_reference_count, 1e-3, 1e9);
  o.fusion.lambda_scale = config.get_double("panorama.lambda_scale", o.fusion.lambda_scale, 0.0, 1e9);
  o.fusion.iterations = config.get_int("panorama.iterations", o.fusion.iterations, 0, 100000);
  o.fusion.lbfgs_memory = config.get_int("panorama.lbfgs_memory", o.fusion.lbfgs_memory, 1, 50);
  o.fusion.data_epsilon_m = config.get_double("panorama.data_epsilon_m", o.fusion.data_epsilon_m, 1e-6, 1.0);
  o.fusion.data_epsilon_final_m =
      config.get_double("panorama.data_epsilon_final_m", o.fusion.data_epsilon_final_m, 1e-7, 1.0);
  o.fusion.relative_tolerance = config.get_double("panorama.tolerance", o.fusion.relative_tolerance, 0.0, 1.0);
  o.fusion.max_coupled_depth_jump_m =
      config.get_double("panorama.max_coupled_depth_jump_m", o.fusion.max_coupled_depth_jump_m, 0.0, 100.0);
  o.fusion.max_sigma_m = config.get_double("panorama.max_sigma_m", o.fusion.max_sigma_m, 1e-6, 100.0);
  o.threads = config.get_int("threads", 0, 0, 1024);
  o.check(config.origin());
  return o;
}

PanoramaResult build_panorama(const ScanIndex& scan, const RigTrajectory& trajectory, const PanoramaOptions& options) {
  options.check();
  // The panorama is the view from the rotation axis (paper §4.2); a walk has no such centre.
  if (scan.rig.motion == RigMotion::kHandheld)
    throw make_error((scan.root / "rig.json").string(), "motion",
                     "handheld: a panorama needs a scan turning in place on a rotator");
  using Clock = std::chrono::steady_clock;
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  PanoramaResult result;
  arena.execute([&] {
    const auto t0 = Clock::now();
    const PanoramaMeasurements measurements = warp_frames(scan, trajectory, options.warp);
    const auto t1 = Clock::now();
    result.panorama = fuse(measurements, options.fusion);
    const auto t2 = Clock::now();
    result.warp_seconds = seconds_between(t0, t1);
    result.fusion_seconds = seconds_between(t1, t2);
    result.measurements = measurements.samples.size();
    result.measurement_bytes = measurements.memory_bytes();
    result.frames_used = measurements.frames_used;
  });
  std::ostringstream msg;
  msg << "panorama: " << result.frames_used << " frames, " << result.measurements << " measurements ("
      << result.measurement_bytes / 1048576.0 << " MiB), warp " << result.warp_seconds << " s, fusion "
      << result.fusion_seconds << " s";
  log_info(msg.str());
  return result;
}

}  // namespace panoscan
