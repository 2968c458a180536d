// The pre-stitched baselines of the paper's Table 1 (§6.2): the three cameras' frames are grouped
// by timestamp and stitched into one tall frame, which a generic single-camera RGB-D tracker
// follows; the frames are then fused with the TSDF baseline (tsdf_baseline.h).
//
//   "EX": each camera placed with the calibrated extrinsics of rig.json (as if the cameras were
//         synchronized and the calibration exact);
//   "GT": each frame placed with its ground-truth pose relative to the reference frame, taken at
//         that camera's own timestamp (the best any stitching can do).
//
// The paper tracked the stitched 640x1280 frames with ORB-SLAM2. We use Open3D's RGB-D odometry
// (Steinbrucker et al. 2011 / Park et al. 2017 hybrid photometric + geometric term), frame to
// frame with poses chained: an outside stand-in for ORB-SLAM2, labelled as such in the tables.
//
// The stitched camera. A virtual pinhole at the reference camera (same pose, so the stitched
// trajectory is directly the reference camera's). Its image is W x H with W = the reference
// camera's width and H = 2 W (the paper: 640x1280 for 640x480 cameras). A square-pixel pinhole
// cannot hold the rig's vertical span (+-67.8 deg for the default pitches of +-45 deg and 45.7 deg
// per camera) in 2 W rows without wasting most columns, so the pixels are not square:
//   fx = the reference camera's fx scaled to W (the same horizontal field and resolution);
//   fy = ((H - 1) / 2) / max |y / z| over the border rays of every camera under the calibrated
//        extrinsics (row 0 and row H-1 see the top of the upper and the bottom of the lower camera);
//   cx, cy = the image centre.
// Near the horizon this halves the vertical resolution of the middle camera (fy ~ 0.46 fx), and
// the upper / lower cameras' widening azimuth range near the zenith / nadir is cropped to the
// reference camera's horizontal field.
//
// Rendering. Each source frame is a mesh of adjacent valid depth pixels (two triangles per 2x2
// block; none across depth edges, where the corner depths differ by more than
// `max_edge_depth_ratio`), transformed into the virtual camera and rasterised with a z-buffer:
// inverse depth is interpolated linearly in the virtual image (exact for planar triangles, the
// rasterisation bound of the tests), colour perspective-correctly. The nearest surface wins where
// cameras overlap.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"
#include "panoscan/recon/tsdf_baseline.h"

namespace panoscan {

struct StitchOptions {
  int width = 0;   // stitch.width: 0 = the reference camera's width
  int height = 0;  // stitch.height: 0 = 2 x width
  // A camera's nearest frame farther than this from the reference frame is left out of the group.
  double max_time_gap_s = 0.0;         // stitch.max_time_gap_s: 0 = half the median reference frame interval
  double max_edge_depth_ratio = 1.05;  // stitch.max_edge_depth_ratio: larger/smaller corner depth of a drawn triangle
  int threads = 0;                     // threads (0 = all cores); the output does not depend on it
  void check(const std::string& origin = "<stitch options>") const;
};

// One stitched frame: the reference camera's frame `reference_frame` and, per sensor, the index of
// its nearest frame in time (-1 = none within max_time_gap_s; the reference sensor's own entry is
// reference_frame).
struct FrameGroup {
  double timestamp = 0.0;  // the reference frame's
  std::size_t reference_frame = 0;
  std::vector<int> frame_of_sensor;
};

struct StitchedFrame {
  double timestamp = 0.0;
  ImageU8 rgb;     // 3 channels, black where nothing was drawn
  ImageF32 depth;  // metres along the virtual optical axis, 0 = nothing drawn
};

// The virtual camera (see the header comment). Throws Error if the rig has no sensors or a
// camera's border rays all point away from the reference camera's view.
PinholeIntrinsics stitched_intrinsics(const RigInfo& rig, const StitchOptions& options);

// Groups by timestamp: one group per reference-camera frame. Throws Error naming the scan and the
// camera if a camera has no frames or the reference camera has fewer than two.
std::vector<FrameGroup> group_frames_by_time(const ScanIndex& scan, const StitchOptions& options);

// The pose of every camera's frame of `group` in the reference frame's camera (= the virtual
// camera): the calibrated extrinsics when `poses` is null ("EX"), else
// poses(reference frame)^-1 * poses(camera's frame) ("GT" when `poses` is the ground truth).
std::vector<Rigid3d> virtual_from_cameras(const ScanIndex& scan, const FrameGroup& group, const RigTrajectory* poses);

// Renders one group into the virtual camera (loads the frames).
StitchedFrame stitch_group(const ScanIndex& scan, const FrameGroup& group, const std::vector<Rigid3d>& virtual_from_cam,
                           const PinholeIntrinsics& stitched, const StitchOptions& options);

struct StitchedScanInfo {
  std::filesystem::path dir;  // the stitched scan (one camera, "stitched")
  PinholeIntrinsics intrinsics;
  std::size_t frames = 0;
  std::size_t missing_camera_frames = 0;  // (group, camera) pairs left out by max_time_gap_s
  double seconds = 0.0;
};

// Stitches every group and writes the sequence as a one-camera scan directory (the format of docs/ARCHITECTURE.md §5,
// camera "stitched", 16-bit depth at the scan's depth scale), atomically. `poses`: see
// virtual_from_cameras; when given it must match the scan (check_rig_trajectory).
StitchedScanInfo write_stitched_scan(const ScanIndex& scan, const std::filesystem::path& out_dir,
                                     const StitchOptions& options, const RigTrajectory* poses, bool overwrite);

// Open3D's RGB-D odometry over a (stitched) scan's first camera, frame i+1 against frame i, each
// step initialised with the previous step's motion (constant velocity; identity for the first).
// A failed step keeps that prediction and is counted. Open3D runs single-threaded inside (it
// merges per-thread sums in arrival order), so the result is reproducible.
struct StitchedOdometryOptions {
  std::vector<int> iterations_per_level = {20, 10, 5};  // coarse to fine (Open3D's default)
  double max_depth_difference_m = 0.07;                 // correspondence gate (Open3D's reconstruction system default)
  double min_depth_m = 0.0;
  double max_depth_m = 4.0;  // as the TSDF cut-off
  void check(const std::string& origin = "<odometry options>") const;
};

struct StitchedOdometryResult {
  RigTrajectory trajectory;  // one sensor; world = the first frame's camera
  int failed_steps = 0;
  double seconds = 0.0;
};

StitchedOdometryResult track_stitched_scan(const ScanIndex& stitched, const StitchedOdometryOptions& options);

// The whole baseline: stitch into `work_dir` (replaced), track, fuse with the TSDF baseline.
// The mesh lives in the frame of the reference camera's first frame.
struct PrestitchedOptions {
  StitchOptions stitch;
  StitchedOdometryOptions odometry;
  TsdfOptions tsdf;
};

struct PrestitchedResult {
  StitchedScanInfo stitched;
  StitchedOdometryResult odometry;
  TsdfResult tsdf;
};

PrestitchedResult run_prestitched_baseline(const ScanIndex& scan, const std::filesystem::path& work_dir,
                                           const PrestitchedOptions& options, const RigTrajectory* poses);

}  // namespace panoscan
