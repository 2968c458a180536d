// Exports for outside systems (exports.h).
#include "panoscan/export/exports.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/version.h"

namespace panoscan {

namespace fs = std::filesystem;

namespace {

// Copies a frame file into the export; a file system error names both paths.
void copy_into(const fs::path& from, const fs::path& to) {
  std::error_code error;
  fs::create_directories(to.parent_path(), error);
  if (!error) fs::copy_file(from, to, fs::copy_options::overwrite_existing, error);
  if (error) throw make_error(to.string(), "", "cannot copy " + from.string() + ": " + error.message());
}

void require_matching(const RigTrajectory& poses, const ScanIndex& scan, const std::string& what) {
  check_rig_trajectory(poses, scan, scan.root.string() + " (" + what + ")");
}

// COLMAP's and nerfstudio's image names: camK/<timestamp>.png.
std::string image_name(const ScanIndex& scan, int sensor, std::size_t frame) {
  return scan.rig.sensors[sensor].name + "/" + format_timestamp(scan.frames[sensor][frame].timestamp) + ".png";
}

std::string tum_listing(const std::string& what, const std::vector<std::pair<double, std::string>>& entries) {
  std::string text = "# " + what + "\n# written by panoscan export prestitched\n# timestamp filename\n";
  for (const auto& [timestamp, file] : entries) text += format_timestamp(timestamp) + " " + file + "\n";
  return text;
}

}  // namespace

PrestitchedExportReport export_prestitched(const ScanIndex& scan, const fs::path& out, const StitchOptions& options,
                                           const RigTrajectory* stitch_poses, const std::string& label,
                                           bool overwrite) {
  if (stitch_poses) require_matching(*stitch_poses, scan, "stitch poses");
  AtomicDirectory dir(out, overwrite);
  const fs::path work = dir.temp_path() / ".stitched-scan";
  const StitchedScanInfo stitched = write_stitched_scan(scan, work, options, stitch_poses, true);
  const ScanIndex sequence = read_scan_index(work);
  const fs::path camera_dir = work / sequence.rig.sensors[0].name;
  // The stitched scan's frame files move into TUM's layout (rgb/, depth/ beside the listings).
  fs::rename(camera_dir / "rgb", dir.temp_path() / "rgb");
  fs::rename(camera_dir / "depth", dir.temp_path() / "depth");
  std::vector<std::pair<double, std::string>> rgb, depth;
  std::vector<double> times;
  for (const FrameEntry& e : sequence.frames[0]) {
    rgb.emplace_back(e.timestamp, e.rgb_file);
    depth.emplace_back(e.timestamp, e.depth_file);
    times.push_back(e.timestamp);
  }
  write_file_atomic(dir.temp_path() / "rgb.txt", tum_listing("color images", rgb));
  write_file_atomic(dir.temp_path() / "depth.txt", tum_listing("depth maps", depth));

  PrestitchedExportReport report;
  report.intrinsics = stitched.intrinsics;
  report.frames = stitched.frames;
  report.missing_camera_frames = stitched.missing_camera_frames;
  // The stitched camera is the reference camera (same pose), so its ground truth is the reference
  // camera's at the reference frames' timestamps.
  const int ref = scan.rig.reference_sensor;
  const fs::path truth_file = scan.root / "groundtruth" / (scan.rig.sensors[ref].name + ".txt");
  if (fs::exists(truth_file)) {
    const std::vector<StampedPose> truth = read_tum_trajectory(truth_file);
    const auto at_frames = interpolate_trajectory(truth, times, 0.02);
    std::vector<StampedPose> poses;
    for (std::size_t k = 0; k < times.size(); ++k)
      if (at_frames[k]) poses.push_back({times[k], *at_frames[k]});
    write_tum_trajectory(dir.temp_path() / "groundtruth.txt", poses);
    report.groundtruth_poses = poses.size();
    // An outside system's output lives in its first frame's camera: this maps it into the scene
    // frame (eval cloud --transform).
    if (!poses.empty() && poses.front().timestamp == times.front())
      write_file_atomic(dir.temp_path() / "scene_from_sequence.txt", pose_matrix_text(poses.front().world_from_cam));
  }
  const PinholeIntrinsics& k = stitched.intrinsics;
  const double depth_scale = scan.rig.sensors[ref].depth_scale;
  write_file_atomic(dir.temp_path() / "calibration.txt", fmt::format("{:.6f} {:.6f} {:.6f} {:.6f}\n", k.fx, k.fy, k.cx, k.cy));
  // ORB-SLAM2's RGB-D settings (its Examples/RGB-D/TUM1.yaml layout): the stitched camera, no
  // distortion, the depth scale; the ORB extractor and viewer entries are ORB-SLAM2's defaults.
  write_file_atomic(dir.temp_path() / "orbslam2.yaml",
                    fmt::format("%YAML:1.0\n# panoscan export prestitched ({} stitching) of {}\n"
                                "Camera.fx: {:.6f}\nCamera.fy: {:.6f}\nCamera.cx: {:.6f}\nCamera.cy: {:.6f}\n"
                                "Camera.k1: 0.0\nCamera.k2: 0.0\nCamera.p1: 0.0\nCamera.p2: 0.0\n"
                                "Camera.width: {}\nCamera.height: {}\nCamera.fps: {:.3f}\nCamera.bf: 40.0\n"
                                "Camera.RGB: 1\nThDepth: 40.0\nDepthMapFactor: {:.6f}\n"
                                "ORBextractor.nFeatures: 1000\nORBextractor.scaleFactor: 1.2\n"
                                "ORBextractor.nLevels: 8\nORBextractor.iniThFAST: 20\nORBextractor.minThFAST: 7\n"
                                "Viewer.KeyFrameSize: 0.05\nViewer.KeyFrameLineWidth: 1\nViewer.GraphLineWidth: 0.9\n"
                                "Viewer.PointSize: 2\nViewer.CameraSize: 0.08\nViewer.CameraLineWidth: 3\n"
                                "Viewer.ViewpointX: 0\nViewer.ViewpointY: -0.7\nViewer.ViewpointZ: -1.8\n"
                                "Viewer.ViewpointF: 500\n",
                                label, scan.root.string(), k.fx, k.fy, k.cx, k.cy, k.width, k.height,
                                scan.rig.sensors[ref].nominal_fps, depth_scale));
  nlohmann::json info = {{"format", "panoscan-export-prestitched"},
                         {"version", 1},
                         {"scan", scan.root.string()},
                         {"stitch", label},
                         {"frames", report.frames},
                         {"missing_camera_frames", report.missing_camera_frames},
                         {"groundtruth_poses", report.groundtruth_poses},
                         {"depth_scale", depth_scale},
                         {"intrinsics",
                          {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}}},
                         {"written_by", {{"version", project_version()}, {"source_revision", source_revision()}}}};
  write_file_atomic(dir.temp_path() / "export.json", info.dump(2) + "\n");
  fs::remove_all(work);
  dir.commit();
  return report;
}

void ColmapExportOptions::check(const std::string& origin) const {
  if (points_per_image < 0 || points_per_image > 100000)
    throw make_error(origin, "export.colmap.points_per_image", "must be in [0, 100000]");
  if (!(depth_agreement > 0 && depth_agreement < 1))
    throw make_error(origin, "export.colmap.depth_agreement", "must be in (0, 1)");
}

ColmapExportReport export_colmap(const ScanIndex& scan, const RigTrajectory& poses, const fs::path& out,
                                 const ColmapExportOptions& options, bool overwrite) {
  options.check("<colmap export options>");
  require_matching(poses, scan, "poses");
  AtomicDirectory dir(out, overwrite);
  const int sensors = int(scan.rig.sensors.size());
  ColmapExportReport report;

  // One image per frame: id, pose, depth (for the tracks), colour (for the points' colour).
  struct Image {
    int id, sensor;
    std::size_t frame;
    Rigid3d cam_from_world;
    ImageF32 depth;
    ImageU8 rgb;
    std::vector<Eigen::Vector2d> points2d;  // COLMAP pixel convention
    std::vector<long> point_ids;
  };
  std::vector<Image> images;
  for (int s = 0; s < sensors; ++s)
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      Image image{int(images.size()) + 1, s, f, poses.world_from_cam[s][f].world_from_cam.inverse(), {}, {}, {}, {}};
      if (options.points_per_image > 0) {
        RgbdFrame frame = load_frame(scan, s, f);
        image.depth = std::move(frame.depth);
        image.rgb = std::move(frame.rgb);
      }
      images.push_back(std::move(image));
      copy_into(scan.root / scan.rig.sensors[s].name / scan.frames[s][f].rgb_file,
                dir.temp_path() / "images" / image_name(scan, s, f));
    }

  // Points: a grid of valid depth pixels per image, observed wherever another image's depth agrees.
  struct Point {
    Eigen::Vector3d world;
    std::array<int, 3> rgb;
    std::vector<std::pair<int, int>> track;  // (image id, point2d index)
  };
  std::vector<Point> points;
  for (Image& source : images) {
    if (options.points_per_image == 0) break;
    const PinholeIntrinsics& in = scan.rig.sensors[source.sensor].intrinsics;
    const int stride = std::max(1, int(std::lround(std::sqrt(double(in.width) * in.height / options.points_per_image))));
    for (int v = stride / 2; v < in.height; v += stride)
      for (int u = stride / 2; u < in.width; u += stride) {
        const float z = source.depth.at(u, v);
        if (!(z > 0)) continue;
        Point point;
        point.world = source.cam_from_world.inverse() * in.backproject(u, v, z);
        point.rgb = {source.rgb.at(u, v, 0), source.rgb.at(u, v, 1), source.rgb.at(u, v, 2)};
        const long id = long(points.size()) + 1;
        for (Image& other : images) {
          Eigen::Vector2d pixel;
          if (&other == &source) {
            pixel = Eigen::Vector2d(u, v);
          } else {
            const PinholeIntrinsics& k = scan.rig.sensors[other.sensor].intrinsics;
            const Eigen::Vector3d in_other = other.cam_from_world * point.world;
            if (in_other.z() <= 0) continue;
            pixel = k.project(in_other);
            if (!k.contains(pixel)) continue;
            const float measured = other.depth.at(int(std::lround(pixel.x())), int(std::lround(pixel.y())));
            if (!(measured > 0) || std::abs(measured - in_other.z()) > options.depth_agreement * in_other.z()) continue;
          }
          point.track.emplace_back(other.id, int(other.points2d.size()));
          other.points2d.push_back(pixel + Eigen::Vector2d(0.5, 0.5));
          other.point_ids.push_back(id);
        }
        report.observations += point.track.size();
        points.push_back(std::move(point));
      }
  }

  std::ostringstream cameras;
  cameras << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
          << "# Number of cameras: " << sensors << "\n";
  for (int s = 0; s < sensors; ++s) {
    const PinholeIntrinsics& k = scan.rig.sensors[s].intrinsics;
    cameras << fmt::format("{} PINHOLE {} {} {:.9g} {:.9g} {:.9g} {:.9g}\n", s + 1, k.width, k.height, k.fx, k.fy,
                           k.cx + 0.5, k.cy + 0.5);
  }
  std::ostringstream image_lines;
  image_lines << "# Image list with two lines of data per image:\n"
              << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
              << "# Number of images: " << images.size() << "\n";
  for (const Image& image : images) {
    const Eigen::Quaterniond q(image.cam_from_world.linear());
    const Eigen::Vector3d& t = image.cam_from_world.translation();
    image_lines << fmt::format("{} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {} {}\n", image.id, q.w(),
                               q.x(), q.y(), q.z(), t.x(), t.y(), t.z(), image.sensor + 1,
                               image_name(scan, image.sensor, image.frame));
    std::string line;
    for (std::size_t k = 0; k < image.points2d.size(); ++k)
      line += fmt::format("{}{:.4f} {:.4f} {}", k ? " " : "", image.points2d[k].x(), image.points2d[k].y(),
                          image.point_ids[k]);
    image_lines << line << "\n";
  }
  std::ostringstream point_lines;
  point_lines << "# 3D point list with one line of data per point:\n"
              << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
              << "# Number of points: " << points.size() << "\n";
  for (std::size_t p = 0; p < points.size(); ++p) {
    const Point& point = points[p];
    point_lines << fmt::format("{} {:.9g} {:.9g} {:.9g} {} {} {} 0", p + 1, point.world.x(), point.world.y(),
                               point.world.z(), point.rgb[0], point.rgb[1], point.rgb[2]);
    for (const auto& [image, index] : point.track) point_lines << " " << image << " " << index;
    point_lines << "\n";
  }
  write_file_atomic(dir.temp_path() / "cameras.txt", cameras.str());
  write_file_atomic(dir.temp_path() / "images.txt", image_lines.str());
  write_file_atomic(dir.temp_path() / "points3D.txt", point_lines.str());
  report.cameras = std::size_t(sensors);
  report.images = images.size();
  report.points = points.size();
  dir.commit();
  return report;
}

NerfstudioExportReport export_nerfstudio(const ScanIndex& scan, const RigTrajectory& poses, const fs::path& out,
                                         bool overwrite) {
  require_matching(poses, scan, "poses");
  AtomicDirectory dir(out, overwrite);
  Eigen::Matrix4d opencv_to_opengl = Eigen::Matrix4d::Identity();
  opencv_to_opengl(1, 1) = -1;
  opencv_to_opengl(2, 2) = -1;
  nlohmann::json frames = nlohmann::json::array();
  double depth_scale = 0;
  for (std::size_t s = 0; s < scan.rig.sensors.size(); ++s) {
    const SensorInfo& sensor = scan.rig.sensors[s];
    if (depth_scale == 0) depth_scale = sensor.depth_scale;
    if (sensor.depth_scale != depth_scale)
      throw make_error((scan.root / "rig.json").string(), "depth_scale",
                       "nerfstudio has one depth_unit_scale_factor: the sensors' depth scales differ");
    const PinholeIntrinsics& k = sensor.intrinsics;
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      const std::string name = image_name(scan, int(s), f);
      copy_into(scan.root / sensor.name / scan.frames[s][f].rgb_file, dir.temp_path() / "images" / name);
      copy_into(scan.root / sensor.name / scan.frames[s][f].depth_file, dir.temp_path() / "depth" / name);
      const Eigen::Matrix4d c2w = poses.world_from_cam[s][f].world_from_cam.matrix() * opencv_to_opengl;
      nlohmann::json matrix = nlohmann::json::array();
      for (int r = 0; r < 4; ++r) matrix.push_back({c2w(r, 0), c2w(r, 1), c2w(r, 2), c2w(r, 3)});
      frames.push_back({{"file_path", "images/" + name},
                        {"depth_file_path", "depth/" + name},
                        {"transform_matrix", std::move(matrix)},
                        {"fl_x", k.fx},
                        {"fl_y", k.fy},
                        {"cx", k.cx + 0.5},
                        {"cy", k.cy + 0.5},
                        {"w", k.width},
                        {"h", k.height},
                        {"k1", 0.0},
                        {"k2", 0.0},
                        {"p1", 0.0},
                        {"p2", 0.0},
                        {"camera", sensor.name},
                        {"timestamp", scan.frames[s][f].timestamp}});
    }
  }
  const nlohmann::json transforms = {
      {"camera_model", "OPENCV"},
      {"depth_unit_scale_factor", 1.0 / depth_scale},
      {"frames", frames},
      {"panoscan",
       {{"scan", scan.root.string()},
        {"poses", poses.source},
        {"axes", "transform_matrix is camera-to-world with camera axes x right, y up, z backwards (OpenGL); "
                 "PanoScan's camera (x right, y down, z forward) is transform_matrix * diag(1, -1, -1, 1)"},
        {"pixel_centres", "cx, cy: the first pixel's centre at (0.5, 0.5); PanoScan's cx, cy + 0.5"},
        {"written_by", {{"version", project_version()}, {"source_revision", source_revision()}}}}}};
  write_file_atomic(dir.temp_path() / "transforms.json", transforms.dump(2) + "\n");
  dir.commit();
  NerfstudioExportReport report;
  report.frames = frames.size();
  return report;
}

}  // namespace panoscan
