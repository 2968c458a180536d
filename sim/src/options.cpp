#include "panoscan/sim/options.h"

#include <cmath>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"

namespace panoscan {

double NoiseOptions::effective_disparity_std() const {
  if (disparity_std >= 0.0) return disparity_std;
  switch (preset) {
    case NoisePreset::kNone: return 0.0;
    case NoisePreset::kHanda:
    case NoisePreset::kHandaIcl: return 1.0 / 6.0;
    // Khoshelham & Elberink 2012: ~0.5 px-equivalent disparity std, 3x ICL-NUIM's.
    case NoisePreset::kKinect: return 0.5;
  }
  return 0.0;
}

const char* to_string(MotionKind kind) { return kind == MotionKind::kHandheld ? "handheld" : "rotator"; }

const char* to_string(NoisePreset preset) {
  switch (preset) {
    case NoisePreset::kNone: return "none";
    case NoisePreset::kHanda: return "handa";
    case NoisePreset::kHandaIcl: return "handa-icl";
    case NoisePreset::kKinect: return "kinect";
  }
  return "?";
}

namespace {

void require(bool ok, const std::string& origin, const std::string& field, const std::string& what) {
  if (!ok) throw make_error(origin, field, what);
}

}  // namespace

void SimOptions::check(const std::string& origin) const {
  require(rig.width >= 16 && rig.width <= 8192, origin, "camera.width", "must be in [16, 8192]");
  require(rig.height >= 12 && rig.height <= 8192, origin, "camera.height", "must be in [12, 8192]");
  require(rig.focal_px > 0 && std::isfinite(rig.focal_px), origin, "camera.focal_px", "must be positive");
  require(!rig.pitches_deg.empty() && rig.pitches_deg.size() <= 8, origin, "rig.pitches_deg", "needs 1 to 8 cameras");
  for (double p : rig.pitches_deg)
    require(std::isfinite(p) && std::abs(p) < 90.0, origin, "rig.pitches_deg", "pitches must lie in (-90, 90) degrees");
  require(rig.reference_sensor >= 0 && rig.reference_sensor < int(rig.pitches_deg.size()), origin,
          "rig.reference_sensor", "must index one of the cameras");
  require(rig.install_offset_m.size() == 3, origin, "rig.install_offset_m", "needs 3 values");
  require(rig.install_rpy_deg.size() == 3, origin, "rig.install_rpy_deg", "needs 3 values");
  require(motion.turn_deg > 0 && motion.turn_deg <= 720, origin, "motion.turn_deg", "must be in (0, 720]");
  require(motion.handheld_duration_s > 0, origin, "motion.handheld_duration_s", "must be positive");
  require(motion.handheld_band_low_hz > 0 && motion.handheld_band_low_hz <= motion.handheld_band_high_hz, origin,
          "motion.handheld_band_hz", "needs 0 < low <= high");
  require(motion.period_s > 0, origin, "motion.period_s", "must be positive");
  require(motion.ramp_s >= 0, origin, "motion.ramp_s", "must not be negative");
  require(motion.speed_band_low_hz > 0 && motion.speed_band_high_hz >= motion.speed_band_low_hz, origin,
          "motion.speed_band_hz", "needs 0 < low <= high");
  require(motion.wobble_band_low_hz > 0 && motion.wobble_band_high_hz >= motion.wobble_band_low_hz, origin,
          "motion.wobble_band_hz", "needs 0 < low <= high");
  require(shutter.fps > 0 && shutter.fps <= 1000, origin, "shutter.fps", "must be in (0, 1000]");
  require(shutter.jitter_ms >= 0 && shutter.jitter_ms < 0.25e3 / shutter.fps, origin, "shutter.jitter_ms",
          "must be non-negative and below a quarter of the frame interval");
  require(noise.min_depth_m > 0 && noise.max_depth_m > noise.min_depth_m, origin, "noise.max_depth_m",
          "needs 0 < min_depth_m < max_depth_m");
  require(noise.max_incidence_deg > 0 && noise.max_incidence_deg <= 90, origin, "noise.max_incidence_deg",
          "must be in (0, 90]");
  require(output.every >= 1, origin, "output.every", "must be at least 1");
  require(output.max_frames >= 0, origin, "output.frames", "must not be negative");
  require(output.min_depth_coverage >= 0.0 && output.min_depth_coverage <= 1.0, origin, "output.min_depth_coverage",
          "must be in [0, 1]");
  require(output.png_compression >= 0 && output.png_compression <= 9, origin, "output.png_compression",
          "must be in [0, 9]");
  require(threads >= 0, origin, "threads", "must not be negative");
}

SimOptions sim_options_from_config(Config& c) {
  SimOptions o;
  o.seed = c.get_u64("seed", o.seed);
  o.threads = c.get_int("threads", o.threads, 0, 1024);

  o.rig.width = c.get_int("camera.width", o.rig.width, 16, 8192);
  o.rig.height = c.get_int("camera.height", o.rig.height, 12, 8192);
  o.rig.focal_px = c.get_double("camera.focal_px", o.rig.focal_px, 1.0, 1e5);
  o.rig.pitches_deg = c.get_doubles("rig.pitches_deg", o.rig.pitches_deg, 0);
  o.rig.reference_sensor = c.get_int("rig.reference_sensor", o.rig.reference_sensor, 0, 7);
  o.rig.camera_spacing_m = c.get_double("rig.camera_spacing_m", o.rig.camera_spacing_m, 0.0, 1.0);
  o.rig.camera_forward_m = c.get_double("rig.camera_forward_m", o.rig.camera_forward_m, -1.0, 1.0);
  o.rig.install_offset_m = c.get_doubles("rig.install_offset_m", o.rig.install_offset_m, 3);
  o.rig.install_rpy_deg = c.get_doubles("rig.install_rpy_deg", o.rig.install_rpy_deg, 3);
  o.rig.calibration_error_deg = c.get_double("rig.calibration_error_deg", o.rig.calibration_error_deg, 0.0, 45.0);
  o.rig.calibration_error_m = c.get_double("rig.calibration_error_m", o.rig.calibration_error_m, 0.0, 1.0);

  o.motion.kind = c.get_string("motion.kind", "rotator", {"rotator", "handheld"}) == "handheld" ? MotionKind::kHandheld
                                                                                              : MotionKind::kRotator;
  o.motion.handheld_duration_s = c.get_double("motion.handheld_duration_s", o.motion.handheld_duration_s, 0.1, 3600.0);
  o.motion.handheld_translation_m =
      c.get_double("motion.handheld_translation_m", o.motion.handheld_translation_m, 0.0, 5.0);
  o.motion.handheld_height_m = c.get_double("motion.handheld_height_m", o.motion.handheld_height_m, 0.0, 1.0);
  o.motion.handheld_yaw_deg = c.get_double("motion.handheld_yaw_deg", o.motion.handheld_yaw_deg, 0.0, 180.0);
  o.motion.handheld_tilt_deg = c.get_double("motion.handheld_tilt_deg", o.motion.handheld_tilt_deg, 0.0, 45.0);
  const auto handheld_band =
      c.get_doubles("motion.handheld_band_hz", {o.motion.handheld_band_low_hz, o.motion.handheld_band_high_hz}, 2);
  o.motion.handheld_band_low_hz = handheld_band[0];
  o.motion.handheld_band_high_hz = handheld_band[1];
  o.motion.turn_deg = c.get_double("motion.turn_deg", o.motion.turn_deg, 1.0, 720.0);
  o.motion.period_s = c.get_double("motion.period_s", o.motion.period_s, 0.1, 3600.0);
  o.motion.ramp_s = c.get_double("motion.ramp_s", o.motion.ramp_s, 0.0, 60.0);
  o.motion.accel_std_deg_s2 = c.get_double("motion.accel_std_deg_s2", o.motion.accel_std_deg_s2, 0.0, 100.0);
  const auto speed_band =
      c.get_doubles("motion.speed_band_hz", {o.motion.speed_band_low_hz, o.motion.speed_band_high_hz}, 2);
  o.motion.speed_band_low_hz = speed_band[0];
  o.motion.speed_band_high_hz = speed_band[1];
  o.motion.wobble_translation_m = c.get_double("motion.wobble_translation_m", o.motion.wobble_translation_m, 0.0, 0.5);
  o.motion.wobble_rotation_deg = c.get_double("motion.wobble_rotation_deg", o.motion.wobble_rotation_deg, 0.0, 20.0);
  const auto wobble_band =
      c.get_doubles("motion.wobble_band_hz", {o.motion.wobble_band_low_hz, o.motion.wobble_band_high_hz}, 2);
  o.motion.wobble_band_low_hz = wobble_band[0];
  o.motion.wobble_band_high_hz = wobble_band[1];
  o.motion.axis_tilt_deg = c.get_double("motion.axis_tilt_deg", o.motion.axis_tilt_deg, 0.0, 10.0);
  o.motion.axis_tilt_azimuth_deg =
      c.get_double("motion.axis_tilt_azimuth_deg", o.motion.axis_tilt_azimuth_deg, -360.0, 360.0);

  o.shutter.fps = c.get_double("shutter.fps", o.shutter.fps, 1e-3, 1000.0);
  o.shutter.jitter_ms = c.get_double("shutter.jitter_ms", o.shutter.jitter_ms, 0.0, 100.0);
  o.shutter.drift_ppm = c.get_double("shutter.drift_ppm", o.shutter.drift_ppm, 0.0, 1e4);
  o.shutter.start_time_s = c.get_double("shutter.start_time_s", o.shutter.start_time_s, 0.0, 1e10);
  o.shutter.synchronized = c.get_bool("shutter.synchronized", o.shutter.synchronized);

  const std::string preset = c.get_string("noise.preset", "handa", {"none", "handa", "handa-icl", "kinect"});
  o.noise.preset = preset == "none"        ? NoisePreset::kNone
                   : preset == "handa-icl" ? NoisePreset::kHandaIcl
                   : preset == "kinect"    ? NoisePreset::kKinect
                                           : NoisePreset::kHanda;
  o.noise.min_depth_m = c.get_double("noise.min_depth_m", o.noise.min_depth_m, 0.01, 100.0);
  o.noise.max_depth_m = c.get_double("noise.max_depth_m", o.noise.max_depth_m, 0.02, 100.0);
  o.noise.max_incidence_deg = c.get_double("noise.max_incidence_deg", o.noise.max_incidence_deg, 1.0, 90.0);
  o.noise.shift_std_px = c.get_double("noise.shift_std_px", o.noise.shift_std_px, 0.0, 10.0);
  o.noise.disparity_std = c.get_double("noise.disparity_std", o.noise.disparity_std, -1.0, 100.0);
  o.noise.ir_speckle = c.get_bool("noise.ir_speckle", o.noise.ir_speckle);
  o.noise.ir_band_fraction = c.get_double("noise.ir_band_fraction", o.noise.ir_band_fraction, 0.0, 0.5);
  o.noise.ir_dropout = c.get_double("noise.ir_dropout", o.noise.ir_dropout, 0.0, 1.0);
  o.noise.ir_disparity_std = c.get_double("noise.ir_disparity_std", o.noise.ir_disparity_std, 0.0, 100.0);
  o.noise.exposure = c.get_bool("noise.exposure", o.noise.exposure);
  o.noise.exposure_std = c.get_double("noise.exposure_std", o.noise.exposure_std, 0.0, 1.0);
  o.noise.white_balance_std = c.get_double("noise.white_balance_std", o.noise.white_balance_std, 0.0, 1.0);
  o.noise.colour_noise_std = c.get_double("noise.colour_noise_std", o.noise.colour_noise_std, 0.0, 64.0);

  o.output.every = c.get_int("output.every", o.output.every, 1, 100000);
  o.output.max_frames = c.get_int("output.frames", o.output.max_frames, 0, 10000000);
  o.output.clean_depth = c.get_bool("output.clean_depth", o.output.clean_depth);
  o.output.normals = c.get_bool("output.normals", o.output.normals);
  o.output.ids = c.get_bool("output.ids", o.output.ids);
  o.output.png_compression = c.get_int("output.png_compression", o.output.png_compression, 0, 9);
  o.output.min_depth_coverage = c.get_double("output.min_depth_coverage", o.output.min_depth_coverage, 0.0, 1.0);
  o.check(c.origin());
  return o;
}

}  // namespace panoscan
