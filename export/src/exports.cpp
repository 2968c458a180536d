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
#include "panoscan/recon/panorama.h"

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

namespace {

// One image of a COLMAP model: its camera, pose, pixels (depth and colour for the 3D points) and
// where its PNG comes from (a scan frame's file is copied; a rendered view is written).
struct ColmapView {
  int camera = 0;  // index into the model's cameras
  Rigid3d cam_from_world = Rigid3d::Identity();
  ImageF32 depth;  // z along the optical axis, 0 = none
  ImageU8 rgb;
  std::string name;      // under images/
  fs::path source_file;  // empty: write `rgb`
};

// Writes cameras.txt, images.txt, points3D.txt and images/ into `dir` (see ColmapExportOptions
// for the points).
ColmapExportReport write_colmap_model(const std::vector<PinholeIntrinsics>& cameras, std::vector<ColmapView>& views,
                                      const fs::path& dir, const ColmapExportOptions& options) {
  ColmapExportReport report;
  struct Observations {
    std::vector<Eigen::Vector2d> points2d;  // COLMAP pixel convention
    std::vector<long> point_ids;
  };
  std::vector<Observations> observed(views.size());
  for (const ColmapView& view : views) {
    if (view.source_file.empty())
      write_png(dir / "images" / view.name, view.rgb);
    else
      copy_into(view.source_file, dir / "images" / view.name);
  }

  // Points: a grid of valid depth pixels per image, observed wherever another image's depth agrees.
  struct Point {
    Eigen::Vector3d world;
    std::array<int, 3> rgb;
    std::vector<std::pair<int, int>> track;  // (image id, point2d index)
  };
  std::vector<Point> points;
  for (std::size_t source = 0; source < views.size() && options.points_per_image > 0; ++source) {
    const ColmapView& view = views[source];
    const PinholeIntrinsics& in = cameras[view.camera];
    const int stride = std::max(1, int(std::lround(std::sqrt(double(in.width) * in.height / options.points_per_image))));
    for (int v = stride / 2; v < in.height; v += stride)
      for (int u = stride / 2; u < in.width; u += stride) {
        const float z = view.depth.at(u, v);
        if (!(z > 0)) continue;
        Point point;
        point.world = view.cam_from_world.inverse() * in.backproject(u, v, z);
        point.rgb = {view.rgb.at(u, v, 0), view.rgb.at(u, v, 1), view.rgb.at(u, v, 2)};
        const long id = long(points.size()) + 1;
        for (std::size_t other = 0; other < views.size(); ++other) {
          Eigen::Vector2d pixel;
          if (other == source) {
            pixel = Eigen::Vector2d(u, v);
          } else {
            const PinholeIntrinsics& k = cameras[views[other].camera];
            const Eigen::Vector3d in_other = views[other].cam_from_world * point.world;
            if (in_other.z() <= 0) continue;
            pixel = k.project(in_other);
            if (!k.contains(pixel)) continue;
            const float measured = views[other].depth.at(int(std::lround(pixel.x())), int(std::lround(pixel.y())));
            if (!(measured > 0) || std::abs(measured - in_other.z()) > options.depth_agreement * in_other.z()) continue;
          }
          point.track.emplace_back(int(other) + 1, int(observed[other].points2d.size()));
          observed[other].points2d.push_back(pixel + Eigen::Vector2d(0.5, 0.5));
          observed[other].point_ids.push_back(id);
        }
        report.observations += point.track.size();
        points.push_back(std::move(point));
      }
  }

  std::ostringstream camera_lines;
  camera_lines << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
               << "# Number of cameras: " << cameras.size() << "\n";
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const PinholeIntrinsics& k = cameras[c];
    camera_lines << fmt::format("{} PINHOLE {} {} {:.9g} {:.9g} {:.9g} {:.9g}\n", c + 1, k.width, k.height, k.fx, k.fy,
                                k.cx + 0.5, k.cy + 0.5);
  }
  std::ostringstream image_lines;
  image_lines << "# Image list with two lines of data per image:\n"
              << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
              << "# Number of images: " << views.size() << "\n";
  for (std::size_t i = 0; i < views.size(); ++i) {
    const Eigen::Quaterniond q(views[i].cam_from_world.linear());
    const Eigen::Vector3d& t = views[i].cam_from_world.translation();
    image_lines << fmt::format("{} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {:.12g} {} {}\n", i + 1, q.w(), q.x(),
                               q.y(), q.z(), t.x(), t.y(), t.z(), views[i].camera + 1, views[i].name);
    std::string line;
    for (std::size_t k = 0; k < observed[i].points2d.size(); ++k)
      line += fmt::format("{}{:.4f} {:.4f} {}", k ? " " : "", observed[i].points2d[k].x(), observed[i].points2d[k].y(),
                          observed[i].point_ids[k]);
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
  write_file_atomic(dir / "cameras.txt", camera_lines.str());
  write_file_atomic(dir / "images.txt", image_lines.str());
  write_file_atomic(dir / "points3D.txt", point_lines.str());
  report.cameras = cameras.size();
  report.images = views.size();
  report.points = points.size();
  return report;
}

// The six faces of a cube around a panorama centre: pano_from_face rotations (columns: the face
// camera's x right, y down, z forward in the panorama frame, z up), 90 degrees each.
std::vector<std::pair<std::string, Eigen::Matrix3d>> cube_faces() {
  std::vector<std::pair<std::string, Eigen::Matrix3d>> faces;
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const std::pair<const char*, Eigen::Vector3d> horizontal[] = {
      {"px", Eigen::Vector3d::UnitX()}, {"py", Eigen::Vector3d::UnitY()}, {"nx", -Eigen::Vector3d::UnitX()},
      {"ny", -Eigen::Vector3d::UnitY()}};
  for (const auto& [name, forward] : horizontal) {
    Eigen::Matrix3d r;
    r.col(2) = forward;
    r.col(1) = -up;                     // image rows go down
    r.col(0) = r.col(1).cross(r.col(2));
    faces.emplace_back(name, r);
  }
  Eigen::Matrix3d top, bottom;
  // Looking up: x right = -y, y down = +x of the panorama frame; looking down: y down = -x.
  top.col(0) = -Eigen::Vector3d::UnitY();
  top.col(1) = Eigen::Vector3d::UnitX();
  top.col(2) = up;
  bottom.col(0) = -Eigen::Vector3d::UnitY();
  bottom.col(1) = -Eigen::Vector3d::UnitX();
  bottom.col(2) = -up;
  faces.emplace_back("pz", top);
  faces.emplace_back("nz", bottom);
  return faces;
}

}  // namespace

ColmapExportReport export_colmap(const ScanIndex& scan, const RigTrajectory& poses, const fs::path& out,
                                 const ColmapExportOptions& options, bool overwrite) {
  options.check("<colmap export options>");
  require_matching(poses, scan, "poses");
  AtomicDirectory dir(out, overwrite);
  std::vector<PinholeIntrinsics> cameras;
  for (const SensorInfo& sensor : scan.rig.sensors) cameras.push_back(sensor.intrinsics);
  std::vector<ColmapView> views;
  for (int s = 0; s < int(scan.rig.sensors.size()); ++s)
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      ColmapView view;
      view.camera = s;
      view.cam_from_world = poses.world_from_cam[s][f].world_from_cam.inverse();
      view.name = image_name(scan, s, f);
      view.source_file = scan.root / scan.rig.sensors[s].name / scan.frames[s][f].rgb_file;
      if (options.points_per_image > 0) {
        RgbdFrame frame = load_frame(scan, s, f);
        view.depth = std::move(frame.depth);
        view.rgb = std::move(frame.rgb);
      }
      views.push_back(std::move(view));
    }
  const ColmapExportReport report = write_colmap_model(cameras, views, dir.temp_path(), options);
  dir.commit();
  return report;
}

ColmapExportReport export_colmap_panoramas(const std::vector<ColmapPanorama>& panoramas, const fs::path& out,
                                           const ColmapExportOptions& options, bool overwrite) {
  options.check("<colmap export options>");
  if (panoramas.empty()) throw make_error(out.string(), "--panoramas", "no panoramas to export");
  const int height = panoramas.front().panorama->pano.height;
  for (const ColmapPanorama& p : panoramas)
    if (p.panorama->pano.height != height)
      throw make_error(p.name, "height", fmt::format("{} rows, the first panorama has {}: one cube size for all",
                                                     p.panorama->pano.height, height));
  // Faces of H/2 pixels: the equator's sampling (2H columns for 360 degrees, H/2 for a face's 90).
  const int size = std::max(2, height / 2);
  PinholeIntrinsics face;
  face.width = face.height = size;
  face.fx = face.fy = 0.5 * size;
  face.cx = face.cy = 0.5 * (size - 1);
  AtomicDirectory dir(out, overwrite);
  std::vector<ColmapView> views;
  for (const ColmapPanorama& p : panoramas) {
    const Panorama& pano = *p.panorama;
    const int w = pano.pano.width(), h = pano.pano.height;
    for (const auto& [face_name, pano_from_face] : cube_faces()) {
      ColmapView view;
      view.camera = 0;
      view.cam_from_world = (pano.world_from_pano * make_rigid(pano_from_face, Eigen::Vector3d::Zero())).inverse();
      view.name = p.name + "/" + face_name + ".png";
      view.rgb = ImageU8(size, size, 3, 0);
      view.depth = ImageF32(size, size, 1, 0.f);
      for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u) {
          const Eigen::Vector3d ray((u - face.cx) / face.fx, (v - face.cy) / face.fy, 1.0);
          const Eigen::Vector2d px = pano.pano.pixel(pano_from_face * ray);
          // Nearest panorama pixel (columns wrap): colour and depth of one measurement, no blending
          // across depth edges.
          const int pu = ((int(std::lround(px.x())) % w) + w) % w;
          const int pv = std::clamp(int(std::lround(px.y())), 0, h - 1);
          for (int c = 0; c < 3; ++c)
            view.rgb.at(u, v, c) = std::uint8_t(std::clamp(pano.colour.at(pu, pv, c) * 255.f + 0.5f, 0.f, 255.f));
          const float radial = pano.depth.at(pu, pv);
          if (radial > 0) view.depth.at(u, v) = float(radial / ray.norm());  // radial distance -> z
        }
      views.push_back(std::move(view));
    }
  }
  const ColmapExportReport report = write_colmap_model({face}, views, dir.temp_path(), options);
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
