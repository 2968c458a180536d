// Scans out to outside systems (issue "real recordings in, standard formats out"):
//   - export_prestitched: the paper's pre-stitched sequence (Table 1's outside rows: ORB-SLAM2,
//     ElasticFusion, InfiniTAM, BundleFusion were fed one tall frame per reference frame) as a TUM
//     RGB-D sequence: rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt, plus the stitched camera
//     as calibration.txt ("fx fy cx cy", ElasticFusion's -cal) and orbslam2.yaml (ORB-SLAM2's RGB-D
//     settings file), scene_from_sequence.txt (the first stitched frame's true pose, 4x4: where an
//     outside system's world lies in the scene; with ground truth only) and export.json.
//   - export_colmap: a COLMAP text model (cameras.txt, images.txt, points3D.txt) with the images
//     under images/, posed by the given trajectory (COLMAP's model_analyzer reads it); of
//     panoramas as cube faces (export_colmap_panoramas).
//   - export_nerfstudio: nerfstudio's transforms.json with per-frame intrinsics and depth paths.
// Pixel conventions: PanoScan puts pixel centres at integer coordinates (OpenCV, TUM); COLMAP and
// nerfstudio put the first pixel's centre at (0.5, 0.5), so their cx, cy and 2D points are ours
// + 0.5. Every output folder is written atomically (AtomicDirectory).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/scan.h"
#include "panoscan/recon/prestitched.h"
#include "panoscan/recon/rig_trajectory.h"

namespace panoscan {

struct Panorama;

struct PrestitchedExportReport {
  PinholeIntrinsics intrinsics;   // the stitched camera
  std::size_t frames = 0;         // one per reference frame
  std::size_t groundtruth_poses = 0;  // in groundtruth.txt (0: the scan has no ground truth)
  std::size_t missing_camera_frames = 0;
};

// `stitch_poses`: null = stitched with the calibrated extrinsics ("EX"), else the relative poses
// of this trajectory (the ground truth: "GT"); `label` ("ex" or "gt") goes into export.json.
PrestitchedExportReport export_prestitched(const ScanIndex& scan, const std::filesystem::path& out,
                                           const StitchOptions& options, const RigTrajectory* stitch_poses,
                                           const std::string& label, bool overwrite);

struct ColmapExportOptions {
  // 3D points: a grid of about this many valid depth pixels per image is back-projected with the
  // image's pose; each point is then observed in every other image whose own depth agrees with the
  // point's depth there within depth_agreement (relative), so points have real tracks. The points
  // come from depth and poses, not from triangulation: their reprojection error is 0 by
  // construction, which COLMAP's analyser reports.
  int points_per_image = 100;     // export.colmap.points_per_image (0 = cameras and images only)
  double depth_agreement = 0.02;  // export.colmap.depth_agreement
  void check(const std::string& origin) const;
};

struct ColmapExportReport {
  std::size_t cameras = 0, images = 0, points = 0, observations = 0;
};

// One COLMAP camera per sensor (PINHOLE), one image per frame named camK/<timestamp>.png.
ColmapExportReport export_colmap(const ScanIndex& scan, const RigTrajectory& poses, const std::filesystem::path& out,
                                 const ColmapExportOptions& options, bool overwrite);

// Panoramas as a COLMAP model: each panorama becomes the six 90-degree faces of a cube around its
// centre (COLMAP has no equirectangular camera), H/2 x H/2 pixels, one PINHOLE camera for all,
// posed by the panorama's world_from_pano; images named <name>/<face>.png, faces px py nx ny (the
// horizontal directions +x, +y, -x, -y of the panorama frame) and pz nz (up, down). The faces take
// the nearest panorama pixel's colour and depth. All panoramas must have one height.
struct ColmapPanorama {
  std::string name;          // unique: the images' folder
  const Panorama* panorama;  // must outlive the call
};
ColmapExportReport export_colmap_panoramas(const std::vector<ColmapPanorama>& panoramas,
                                           const std::filesystem::path& out, const ColmapExportOptions& options,
                                           bool overwrite);

struct NerfstudioExportReport {
  std::size_t frames = 0;
};

// transforms.json: "camera_model": "OPENCV" (no distortion), per frame "file_path" (images/camK/<ts>.png),
// "depth_file_path" (depth/camK/<ts>.png, the scan's 16-bit PNG; "depth_unit_scale_factor" = 1 /
// depth_scale), the intrinsics and "transform_matrix": camera-to-world in nerfstudio's (OpenGL)
// camera axes, x right, y up, z backwards: world_from_cam * diag(1, -1, -1, 1).
NerfstudioExportReport export_nerfstudio(const ScanIndex& scan, const RigTrajectory& poses,
                                         const std::filesystem::path& out, bool overwrite);

}  // namespace panoscan
