// Simulator settings: plain structs whose defaults are the paper's set-up (paper §6.1;
// docs/ARCHITECTURE.md §6).
// Filled from a config file plus command-line overrides by sim_options_from_config(); every
// field has its config key in the comment.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace panoscan {
class Config;

struct RigOptions {
  int width = 640;                                       // camera.width
  int height = 480;                                      // camera.height
  double focal_px = 570.0;                               // camera.focal_px (at 640 columns; scaled with width)
  std::vector<double> pitches_deg = {45.0, 0.0, -45.0};  // rig.pitches_deg (one camera per entry)
  int reference_sensor = 1;                              // rig.reference_sensor (the middle camera)
  double camera_spacing_m = 0.06;                        // rig.camera_spacing_m (vertical, on the bracket)
  double camera_forward_m = 0.02;                        // rig.camera_forward_m (lens ahead of the bracket plate)
  // Installation of the bracket on the rotator (the unknown T_u): axis_from_bracket.
  std::vector<double> install_offset_m = {0.08, 0.03, 1.10};  // rig.install_offset_m (forward, left, up)
  std::vector<double> install_rpy_deg = {0.6, -1.2, 3.0};     // rig.install_rpy_deg (roll, pitch, yaw)
  // Error of the calibrated extrinsics handed to reconstruction (random direction, this size).
  double calibration_error_deg = 0.5;  // rig.calibration_error_deg
  double calibration_error_m = 0.005;  // rig.calibration_error_m
};

enum class MotionKind { kRotator, kHandheld };

struct MotionOptions {
  // motion.kind: rotator (the paper's in-place turn, below) or handheld: a seeded, smooth walk
  // about the scanning position (the handheld_* keys, plus the wobble as hand tremor), written with
  // rig.json "motion": handheld, for tracking that must not assume a rotation (TUM-like sequences).
  MotionKind kind = MotionKind::kRotator;
  double turn_deg = 360.0;              // motion.turn_deg: total rotation
  double period_s = 32.0;               // motion.period_s: seconds per 360 deg at cruise speed
  double ramp_s = 1.0;                  // motion.ramp_s: raised-cosine ramp at start and stop
  double accel_std_deg_s2 = 1.0;        // motion.accel_std_deg_s2: random angular acceleration std
  double speed_band_low_hz = 0.1;       // motion.speed_band_hz[0]
  double speed_band_high_hz = 0.5;      // motion.speed_band_hz[1]
  double wobble_translation_m = 0.005;  // motion.wobble_translation_m: std per axis
  double wobble_rotation_deg = 0.5;     // motion.wobble_rotation_deg: std per axis
  double wobble_band_low_hz = 0.5;      // motion.wobble_band_hz[0]
  double wobble_band_high_hz = 4.0;     // motion.wobble_band_hz[1]
  double axis_tilt_deg = 0.0;           // motion.axis_tilt_deg: axis vs gravity
  double axis_tilt_azimuth_deg = 30.0;  // motion.axis_tilt_azimuth_deg
  // Handheld walk: each component a sum of sinusoids in the band with exactly this std over the
  // recording, starting at the scanning position (zero offset at t = 0).
  double handheld_duration_s = 10.0;            // motion.handheld_duration_s
  double handheld_translation_m = 0.15;         // motion.handheld_translation_m: std per horizontal axis
  double handheld_height_m = 0.05;              // motion.handheld_height_m: std of the height
  double handheld_yaw_deg = 30.0;               // motion.handheld_yaw_deg: std of the heading
  double handheld_tilt_deg = 5.0;               // motion.handheld_tilt_deg: std of pitch and roll (about the floor point)
  double handheld_band_low_hz = 0.05;           // motion.handheld_band_hz[0]
  double handheld_band_high_hz = 0.3;           // motion.handheld_band_hz[1]
};
const char* to_string(MotionKind kind);  // "rotator", "handheld"

struct ShutterOptions {
  double fps = 30.0;          // shutter.fps
  double jitter_ms = 0.3;     // shutter.jitter_ms: std of per-frame timestamp jitter
  double drift_ppm = 50.0;    // shutter.drift_ppm: max clock-rate error per camera
  double start_time_s = 0.0;  // shutter.start_time_s: timestamp of the start of motion
  // shutter.synchronized: all cameras triggered together (no offsets, drift or jitter), for the
  // ablation that shows the method does not rely on synchronisation. Timestamps stay unique
  // (they differ by a microsecond or two).
  bool synchronized = false;
};

enum class NoisePreset { kNone, kHanda, kHandaIcl, kKinect };

struct NoiseOptions {
  NoisePreset preset = NoisePreset::kHanda;  // noise.preset: none | handa | handa-icl | kinect
  double min_depth_m = 0.5;                  // noise.min_depth_m
  double max_depth_m = 8.0;                  // noise.max_depth_m
  double max_incidence_deg = 82.0;           // noise.max_incidence_deg (ray vs normal)
  double shift_std_px = 0.5;                 // noise.shift_std_px (Handa step 1)
  // Disparity noise std in 1/8-pixel disparity units: 1/6 for handa(-icl), 0.5 for kinect.
  // Negative means "the preset's value".
  double disparity_std = -1.0;  // noise.disparity_std
  // Extras beyond the paper (§6.5 limitations), off by default.
  bool ir_speckle = false;          // noise.ir_speckle: interference in overlap bands
  double ir_band_fraction = 0.08;   // noise.ir_band_fraction: image height fraction per band
  double ir_dropout = 0.3;          // noise.ir_dropout: probability of a hole in the band
  double ir_disparity_std = 1.0;    // noise.ir_disparity_std: extra disparity noise in the band
  bool exposure = false;            // noise.exposure: per-camera exposure / white balance
  double exposure_std = 0.12;       // noise.exposure_std: relative gain std
  double white_balance_std = 0.06;  // noise.white_balance_std: per-channel gain std
  double colour_noise_std = 0.0;    // noise.colour_noise_std: 8-bit levels

  double effective_disparity_std() const;
};

struct OutputOptions {
  int every = 1;             // output.every: render every n-th frame of each camera (paper's n)
  int max_frames = 0;        // output.frames: frames per camera after `every` (0 = whole turn)
  bool clean_depth = false;  // output.clean_depth: also write noiseless depth
  // Per-frame ground truth of the noiseless ray under groundtruth/ (format: core/scan.h,
  // groundtruth_normals_path): the hit triangle's normal in the camera frame (EXR float), and the
  // hit triangle's and its material's ids (EXR 32-bit UINT).
  bool normals = false;      // output.normals: groundtruth/normals/camK/<ts>.exr
  bool ids = false;          // output.ids: groundtruth/ids/camK/<ts>.exr
  int png_compression = 1;   // output.png_compression: 0..9
  // The scan is refused (naming the position) when fewer than this share of the pixels of a probe
  // of the turn (12 frames per camera, before anything is written) have depth in the sensor's
  // range: the rig is outside the room, inside an object, or facing nothing. 0 = no check.
  double min_depth_coverage = 0.2;  // output.min_depth_coverage
};

struct SimOptions {
  RigOptions rig;
  MotionOptions motion;
  ShutterOptions shutter;
  NoiseOptions noise;
  OutputOptions output;
  std::uint64_t seed = 1;  // seed
  int threads = 0;         // threads (0 = all cores)

  // Throws Error naming `origin` and the field for values out of range.
  void check(const std::string& origin = "<options>") const;
};

// Reads every key above from the config (unknown keys are rejected by the caller's
// Config::check_all_used()).
SimOptions sim_options_from_config(Config& config);

const char* to_string(NoisePreset preset);

}  // namespace panoscan
