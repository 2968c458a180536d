// `panoscan import tum`: TUM RGB-D sequences (one per sensor) become a scan folder (scan.h,
// docs/ARCHITECTURE.md §5.4).
//
// A TUM sequence folder holds rgb.txt and depth.txt (listings "timestamp filename", tum_listing.h),
// the images they list (8-bit colour, 16-bit depth in depth_scale units per metre) and optionally
// groundtruth.txt (TUM trajectory, world_from_cam of the colour camera, "tx ty tz qx qy qz qw").
// Per sensor the importer pairs colour and depth images by nearest timestamp within max_dt
// (associate_timestamps, as TUM's associate.py); each pair becomes a frame stamped with its colour
// image's timestamp, whose files are copied (or hard-linked) unchanged. groundtruth.txt, when
// present, becomes groundtruth/camK.txt at those timestamps (interpolate_trajectory within max_dt;
// frames it does not cover get no pose). rig.json gets the intrinsics (given, a preset, or the
// preset the folder name implies), depth_scale, the extrinsics, the motion; import.json records the
// inputs, the options and what was associated and dropped.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/scan.h"

namespace panoscan {

// The published TUM RGB-D intrinsics (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats)
// of the 640x480 colour images: fr1 (517.3, 516.5, 318.6, 255.3), fr2 (520.9, 521.0, 325.1, 249.7),
// fr3 (535.4, 539.2, 320.1, 247.6), ros (525.0, 525.0, 319.5, 239.5: ROS's default, with which
// TUM registered depth to colour). fr1 and fr2 colour images carry lens distortion that the
// pinhole scan format does not model.
struct TumCameraPreset {
  std::string name;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};
const std::vector<TumCameraPreset>& tum_camera_presets();
// The preset of `name` (Error naming `origin` and listing the presets if there is none).
const TumCameraPreset& tum_camera_preset(const std::string& name, const std::string& origin);
// The preset a TUM folder name implies ("rgbd_dataset_freiburg2_desk" -> "fr2"), "" if none.
std::string tum_preset_for_folder(const std::filesystem::path& folder);

struct TumImportOptions {
  std::vector<std::filesystem::path> inputs;  // sensor K = inputs[K] (named camK)
  std::filesystem::path out;                  // the scan folder to write
  // Each "fx,fy,cx,cy"; none, one for every sensor, or one per sensor. Exclusive with `cameras`.
  std::vector<std::string> intrinsics;
  // Preset names (tum_camera_presets); none, one, or one per sensor. With neither, each input's
  // folder name must imply a preset.
  std::vector<std::string> cameras;
  // JSON {"ref_from_cam": [one per sensor], "reference_sensor": K (optional, default 0)}; each
  // entry a 4x4 row-major matrix [[...],[...],[...],[0,0,0,1]] or a pose object
  // {"translation": [...], "rotation_quaternion_xyzw": [...]}. Required for more than one
  // sensor; one sensor without it is its own reference (identity).
  std::filesystem::path extrinsics_file;
  double depth_scale = 5000.0;  // depth PNG units per metre (TUM: 5000)
  double max_dt = 0.02;         // seconds: association and ground-truth interpolation window
  bool hard_link = false;       // hard-link the images instead of copying them
  RigMotion motion = RigMotion::kHandheld;
  bool overwrite = false;
};

struct TumImportSensorReport {
  std::filesystem::path input;
  std::string intrinsics_source;  // "--intrinsics", "--camera fr1", "folder name: fr1"
  std::size_t rgb_listed = 0, depth_listed = 0;
  std::size_t frames = 0;  // associated pairs, each a frame of the scan
  std::size_t rgb_dropped = 0, depth_dropped = 0;
  double max_abs_dt = 0.0;  // seconds, over the associated pairs
  bool has_groundtruth = false;
  std::size_t groundtruth_poses = 0;     // poses in groundtruth.txt
  std::size_t frames_with_pose = 0;      // frames groundtruth/camK.txt covers
};

struct TumImportReport {
  RigInfo rig;
  std::vector<TumImportSensorReport> sensors;
};

// Writes the scan atomically (ScanWriter) and returns what it did. Throws Error naming the file
// and the line (listings, groundtruth.txt) or the option: a missing listing, a listed file that
// is not there, a depth image that is not a 16-bit single-channel PNG, a colour image that is not
// 8-bit, images of different sizes, timestamps out of order, no associable pairs, a preset for
// another image size, a malformed extrinsics file, an existing output without `overwrite`.
TumImportReport import_tum(const TumImportOptions& options);

}  // namespace panoscan
