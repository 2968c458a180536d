// Exports for outside systems (export/exports.h, `panoscan export ...`) on a small simulated scan:
//   - prestitched: a TUM RGB-D sequence that PanoScan's own `import tum` reads back (listings,
//     16-bit depth, calibration.txt as the intrinsics) with the reference camera's ground truth;
//     "gt" and "ex" stitching differ (the calibration carries an error);
//   - colmap: the text model's poses are the truth, every observation reprojects onto its point,
//     points have tracks, and COLMAP's own model_analyzer reads it (skipped without colmap);
//   - nerfstudio: transforms.json's matrices are the truth in OpenGL axes, the files exist;
//   - the program's refusals.

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/tum_import.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/export/exports.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/sim/renderer.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class ExportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testutil::TempDir("export");
    const Scene scene = testutil::make_box_room(-1.6, 3.3, -2.1, 2.4, 2.7, Eigen::Vector3d(0, 0, 0));
    SimOptions options;
    options.rig.width = 80;
    options.rig.height = 60;
    options.output.every = 90;
    options.threads = 2;
    options.seed = 4;
    Simulator(scene, 0, options).write_scan(dir_->path() / "scan", false);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path scan_dir() { return dir_->path() / "scan"; }
  static testutil::TempDir* dir_;
};
testutil::TempDir* ExportTest::dir_ = nullptr;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::vector<std::string> data_lines(const fs::path& path) {
  std::vector<std::string> lines;
  std::istringstream in(read_text(path));
  for (std::string line; std::getline(in, line);)
    if (line.empty() || line[0] != '#') lines.push_back(line);
  return lines;
}

TEST_F(ExportTest, PrestitchedIsATumSequenceThatImportsBack) {
  const ScanIndex scan = read_scan_index(scan_dir());
  const int ref = scan.rig.reference_sensor;
  const fs::path out = dir_->path() / "prestitched-ex";
  const PrestitchedExportReport report = export_prestitched(scan, out, StitchOptions{}, nullptr, "ex", false);
  EXPECT_EQ(report.frames, scan.frames[ref].size());
  EXPECT_EQ(report.intrinsics.width, 80);
  EXPECT_EQ(report.intrinsics.height, 160);
  EXPECT_EQ(report.groundtruth_poses, report.frames);
  for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt", "calibration.txt", "orbslam2.yaml", "export.json"})
    EXPECT_TRUE(fs::exists(out / name)) << name;
  EXPECT_FALSE(fs::exists(out / ".stitched-scan"));
  EXPECT_TRUE(read_pose_file(out / "scene_from_sequence.txt")
                  .isApprox(read_groundtruth_trajectory(scan_dir(), ref).front().world_from_cam, 1e-12));
  EXPECT_THAT(read_text(out / "orbslam2.yaml"), HasSubstr("DepthMapFactor: 5000"));

  // Through PanoScan's own TUM importer, with calibration.txt's intrinsics.
  std::istringstream calibration(read_text(out / "calibration.txt"));
  double fx, fy, cx, cy;
  calibration >> fx >> fy >> cx >> cy;
  EXPECT_NEAR(fx, report.intrinsics.fx, 1e-5);
  TumImportOptions import;
  import.inputs = {out};
  import.out = dir_->path() / "reimported";
  import.intrinsics = {std::to_string(fx) + "," + std::to_string(fy) + "," + std::to_string(cx) + "," +
                       std::to_string(cy)};
  import.motion = RigMotion::kRotator;
  const TumImportReport imported = import_tum(import);
  ASSERT_EQ(imported.sensors.size(), 1u);
  EXPECT_EQ(imported.sensors[0].frames, report.frames);
  EXPECT_EQ(imported.sensors[0].frames_with_pose, report.frames);
  const ScanIndex back = read_scan_index(import.out);
  const std::vector<StampedPose> truth = read_groundtruth_trajectory(scan_dir(), ref);
  const std::vector<StampedPose> back_truth = read_groundtruth_trajectory(import.out, 0);
  ASSERT_EQ(back_truth.size(), truth.size());
  for (std::size_t f = 0; f < truth.size(); ++f) {
    EXPECT_NEAR(back.frames[0][f].timestamp, scan.frames[ref][f].timestamp, 1e-6);
    EXPECT_TRUE(back_truth[f].world_from_cam.isApprox(truth[f].world_from_cam, 1e-6)) << f;
  }
  // The stitched frame holds the reference camera's view: its middle rows see what that camera sees.
  const RgbdFrame stitched = load_frame(back, 0, 0);
  int drawn = 0;
  for (float z : stitched.depth.data) drawn += z > 0;
  EXPECT_GT(drawn, int(stitched.depth.data.size() / 2));

  // GT stitching places each camera with its true relative pose: other pixels than EX's.
  const RigTrajectory gt = eval::groundtruth_rig_trajectory(scan_dir());
  const fs::path out_gt = dir_->path() / "prestitched-gt";
  export_prestitched(scan, out_gt, StitchOptions{}, &gt, "gt", false);
  EXPECT_NE(read_text(out_gt / "rgb" / fs::path(back.frames[0][0].rgb_file).filename()),
            read_text(out / "rgb" / fs::path(back.frames[0][0].rgb_file).filename()));
  EXPECT_EQ(read_json_file(out_gt / "export.json").at("stitch"), "gt");
}

// One image line of COLMAP's images.txt: "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME".
struct ColmapImage {
  int camera = 0;
  Rigid3d cam_from_world = Rigid3d::Identity();
  std::string name;
};

ColmapImage parse_image_line(const std::string& line) {
  std::istringstream in(line);
  int id;
  double qw, qx, qy, qz, tx, ty, tz;
  ColmapImage image;
  in >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> image.camera >> image.name;
  image.cam_from_world = make_rigid(Eigen::Quaterniond(qw, qx, qy, qz).normalized(), Eigen::Vector3d(tx, ty, tz));
  return image;
}

TEST_F(ExportTest, ColmapModelHasTheTruePosesAndConsistentTracks) {
  const ScanIndex scan = read_scan_index(scan_dir());
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan_dir());
  const fs::path out = dir_->path() / "colmap";
  ColmapExportOptions options;
  options.points_per_image = 40;
  const ColmapExportReport report = export_colmap(scan, truth, out, options, false);
  std::size_t frames = 0;
  for (const auto& f : scan.frames) frames += f.size();
  EXPECT_EQ(report.cameras, 3u);
  EXPECT_EQ(report.images, frames);
  EXPECT_GT(report.points, frames * 20);
  EXPECT_GT(report.observations, report.points * 3 / 2);  // tracks across images, not one view each

  // cameras.txt: PINHOLE with COLMAP's pixel centres (+0.5).
  std::map<int, std::vector<double>> cameras;
  for (const std::string& line : data_lines(out / "cameras.txt")) {
    std::istringstream in(line);
    int id, w, h;
    std::string model;
    double fx, fy, cx, cy;
    in >> id >> model >> w >> h >> fx >> fy >> cx >> cy;
    EXPECT_EQ(model, "PINHOLE");
    cameras[id] = {fx, fy, cx, cy};
    EXPECT_NEAR(cx, scan.rig.sensors[id - 1].intrinsics.cx + 0.5, 1e-9);
  }
  ASSERT_EQ(cameras.size(), 3u);
  // points3D.txt
  std::map<long, Eigen::Vector3d> points;
  for (const std::string& line : data_lines(out / "points3D.txt")) {
    std::istringstream in(line);
    long id;
    double x, y, z;
    in >> id >> x >> y >> z;
    points[id] = Eigen::Vector3d(x, y, z);
  }
  EXPECT_EQ(points.size(), report.points);
  // images.txt: the pose is cam_from_world of the truth; each observation reprojects onto its point.
  const std::vector<std::string> lines = data_lines(out / "images.txt");
  ASSERT_EQ(lines.size(), 2 * frames);
  std::size_t observations = 0;
  double worst_px = 0;
  for (std::size_t k = 0; k < lines.size(); k += 2) {
    const ColmapImage image = parse_image_line(lines[k]);
    const int camera = image.camera, sensor = camera - 1;
    const std::string& name = image.name;
    const std::string ts = fs::path(name).stem().string();
    std::size_t frame = 0;
    while (format_timestamp(scan.frames[sensor][frame].timestamp) != ts) ++frame;
    EXPECT_TRUE(fs::exists(out / "images" / name)) << name;
    const Rigid3d& cam_from_world = image.cam_from_world;
    EXPECT_TRUE(cam_from_world.isApprox(truth.world_from_cam[sensor][frame].world_from_cam.inverse(), 1e-8)) << name;
    std::istringstream obs(lines[k + 1]);
    double u, v;
    long point;
    const std::vector<double>& c = cameras[camera];
    while (obs >> u >> v >> point) {
      const Eigen::Vector3d p = cam_from_world * points.at(point);
      const double du = c[0] * p.x() / p.z() + c[2] - u, dv = c[1] * p.y() / p.z() + c[3] - v;
      worst_px = std::max(worst_px, std::hypot(du, dv));
      ++observations;
    }
  }
  EXPECT_EQ(observations, report.observations);
  EXPECT_LT(worst_px, 1e-3);

  // COLMAP's own reader and analyser.
  if (std::system("colmap help > /dev/null 2>&1") != 0) {
    std::printf("colmap is not installed: the model_analyzer check is skipped (scripts/setup.sh installs it)\n");
    return;
  }
  const std::string log = (dir_->path() / "analyzer.log").string();
  ASSERT_EQ(std::system(("colmap model_analyzer --path " + out.string() + " > " + log + " 2>&1").c_str()), 0)
      << read_text(log);
  const std::string analysed = read_text(log);
  std::printf("%s", analysed.c_str());
  EXPECT_THAT(analysed, HasSubstr("Cameras: 3"));
  EXPECT_THAT(analysed, HasSubstr("Registered images: " + std::to_string(frames)));
  EXPECT_THAT(analysed, HasSubstr("Points: " + std::to_string(report.points)));
  EXPECT_THAT(analysed, HasSubstr("Observations: " + std::to_string(report.observations)));
}

TEST(ExportPanoramas, CubeFacesSeeWhatAPinholeCameraAtThePanoramaCentreSees) {
  // A ground-truth panorama of the box room, exported as cube faces: each face's depth and pose
  // must match a pinhole rendering of the room from the same pose.
  testutil::TempDir dir("export-pano");
  const Scene scene = testutil::make_box_room(-1.6, 3.3, -2.1, 2.4, 2.7, Eigen::Vector3d(0, 0, 0));
  const Renderer renderer(scene);
  Panorama panorama;
  panorama.pano.height = 128;
  panorama.world_from_pano =
      make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.1, 1.2)) * rotation_about(Eigen::Vector3d::UnitZ(), 0.3);
  const RenderedView view = renderer.render_equirectangular(panorama.world_from_pano, panorama.pano);
  panorama.depth = view.depth;
  panorama.colour = ImageF32(view.rgb.width, view.rgb.height, 3, 0.f);
  for (std::size_t i = 0; i < view.rgb.data.size(); ++i) panorama.colour.data[i] = view.rgb.data[i] / 255.f;
  ColmapExportOptions options;
  options.points_per_image = 50;
  const ColmapExportReport report =
      export_colmap_panoramas({{"pano-a", &panorama}}, dir.path() / "colmap", options, false);
  EXPECT_EQ(report.cameras, 1u);
  EXPECT_EQ(report.images, 6u);
  EXPECT_GE(report.observations, report.points);  // the faces do not overlap: tracks of one, but edges

  const std::vector<std::string> cameras = data_lines(dir.path() / "colmap" / "cameras.txt");
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras[0], "1 PINHOLE 64 64 32 32 32 32");  // 90 degrees, centre 31.5 + 0.5
  PinholeIntrinsics face;
  face.width = face.height = 64;
  face.fx = face.fy = 32;
  face.cx = face.cy = 31.5;
  const std::vector<std::string> lines = data_lines(dir.path() / "colmap" / "images.txt");
  ASSERT_EQ(lines.size(), 12u);
  std::vector<Eigen::Vector3d> forwards;
  for (std::size_t k = 0; k < lines.size(); k += 2) {
    const ColmapImage image = parse_image_line(lines[k]);
    const std::string& name = image.name;
    const Rigid3d world_from_face = image.cam_from_world.inverse();
    EXPECT_TRUE(world_from_face.translation().isApprox(panorama.world_from_pano.translation(), 1e-9)) << name;
    EXPECT_NEAR(world_from_face.linear().determinant(), 1.0, 1e-9);
    forwards.push_back(world_from_face.linear().col(2));
    // The face's colour is what a pinhole camera there sees: compared as 8x8-pixel block means
    // (the nearest panorama pixel and the pinhole's own texture filtering differ pixel by pixel
    // on the room's fine textures, not on average).
    const ImageU8 exported = read_rgb(dir.path() / "colmap" / "images" / name);
    const RenderedView pinhole = renderer.render(world_from_face, face);
    ASSERT_EQ(exported.data.size(), pinhole.rgb.data.size());
    int blocks = 0, close = 0;
    for (int by = 0; by < 64; by += 8)
      for (int bx = 0; bx < 64; bx += 8) {
        double a = 0, b = 0;
        for (int y = by; y < by + 8; ++y)
          for (int x = bx; x < bx + 8; ++x)
            for (int c = 0; c < 3; ++c) {
              a += exported.at(x, y, c);
              b += pinhole.rgb.at(x, y, c);
            }
        ++blocks;
        close += std::abs(a - b) / (64 * 3) < 12;
      }
    EXPECT_GE(close, int(0.9 * blocks)) << name;
  }
  // Six distinct axis directions: the cube.
  for (std::size_t i = 0; i < forwards.size(); ++i)
    for (std::size_t j = i + 1; j < forwards.size(); ++j) EXPECT_LT(forwards[i].dot(forwards[j]), 1e-9);
  // Every 3D point lies on the room's surface as seen from the centre: radial depth turned into
  // z-depth and back-projected through the right face.
  int checked = 0;
  for (const std::string& line : data_lines(dir.path() / "colmap" / "points3D.txt")) {
    std::istringstream in(line);
    long id;
    Eigen::Vector3d p;
    in >> id >> p.x() >> p.y() >> p.z();
    const Eigen::Vector3d ray = p - panorama.world_from_pano.translation();
    const double hit = renderer.cast(panorama.world_from_pano.translation(), ray.normalized());
    EXPECT_NEAR(hit, ray.norm(), 0.03 * ray.norm()) << id;
    ++checked;
  }
  EXPECT_EQ(checked, int(report.points));
}

TEST_F(ExportTest, NerfstudioTransformsAreTheTruthInOpenGlAxes) {
  const ScanIndex scan = read_scan_index(scan_dir());
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan_dir());
  const fs::path out = dir_->path() / "nerfstudio";
  const NerfstudioExportReport report = export_nerfstudio(scan, truth, out, false);
  const nlohmann::json transforms = read_json_file(out / "transforms.json");
  EXPECT_EQ(transforms.at("camera_model"), "OPENCV");
  EXPECT_DOUBLE_EQ(transforms.at("depth_unit_scale_factor").get<double>(), 1.0 / 5000.0);
  const auto& frames = transforms.at("frames");
  ASSERT_EQ(frames.size(), report.frames);
  std::size_t k = 0;
  for (std::size_t s = 0; s < scan.frames.size(); ++s)
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f, ++k) {
      const auto& frame = frames.at(k);
      EXPECT_TRUE(fs::exists(out / frame.at("file_path").get<std::string>()));
      EXPECT_TRUE(fs::exists(out / frame.at("depth_file_path").get<std::string>()));
      EXPECT_DOUBLE_EQ(frame.at("cx").get<double>(), scan.rig.sensors[s].intrinsics.cx + 0.5);
      Eigen::Matrix4d c2w;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) c2w(r, c) = frame.at("transform_matrix").at(r).at(c).get<double>();
      // OpenGL camera: y up, z backwards; flipping both gives the OpenCV camera back.
      const Eigen::Matrix4d opencv = c2w * Eigen::Vector4d(1, -1, -1, 1).asDiagonal();
      EXPECT_TRUE(opencv.isApprox(truth.world_from_cam[s][f].world_from_cam.matrix(), 1e-12)) << k;
      // The camera looks along -z of its OpenGL frame: the optical axis in the world.
      const Eigen::Vector3d forward = truth.world_from_cam[s][f].world_from_cam.linear().col(2);
      EXPECT_TRUE((-c2w.block<3, 1>(0, 2)).isApprox(forward, 1e-12));
    }
  // The depth file is the scan's own 16-bit PNG.
  const ImageU16 depth = read_png16(out / frames.at(0).at("depth_file_path").get<std::string>());
  EXPECT_EQ(depth.width, 80);
}

TEST_F(ExportTest, AnOutsideCloudInTheSequenceFrameIsEvaluatedInTheSceneFrame) {
  // A cloud as an outside system would write it: in the first stitched frame's camera.
  const ScanIndex scan = read_scan_index(scan_dir());
  const fs::path out = dir_->path() / "prestitched-eval";
  export_prestitched(scan, out, StitchOptions{}, nullptr, "ex", false);
  const Rigid3d scene_from_sequence = read_pose_file(out / "scene_from_sequence.txt");
  const TriangleMesh mesh = read_ply_mesh(scan_dir() / "groundtruth" / "mesh.ply");
  PointCloud cloud;
  for (const Eigen::Vector3f& v : mesh.vertices)
    cloud.positions.push_back(scene_from_sequence.inverse() * v.cast<double>());
  write_ply_point_cloud(dir_->path() / "outside.ply", cloud);
  const auto rmse_mm = [&](const std::string& extra) {
    const fs::path json = dir_->path() / "outside.json";
    const auto r = testutil::run_panoscan("eval cloud --cloud " + (dir_->path() / "outside.ply").string() +
                                          " --scan " + scan_dir().string() + " --json " + json.string() + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return read_json_file(json).at("accuracy").at("rmse_mm").get<double>();
  };
  EXPECT_LT(rmse_mm(" --transform " + (out / "scene_from_sequence.txt").string()), 1e-3);
  EXPECT_GT(rmse_mm(""), 10.0);  // without the transform the cloud is off by the rig's height
}

TEST_F(ExportTest, TheProgramExportsAndRefusesBadArguments) {
  const auto ok = testutil::run_panoscan("export nerfstudio --scan " + scan_dir().string() + " --out " +
                                         (dir_->path() / "cli-ns").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("transforms.json"));
  const auto again = testutil::run_panoscan("export nerfstudio --scan " + scan_dir().string() + " --out " +
                                            (dir_->path() / "cli-ns").string());
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_THAT(again.output, HasSubstr("already exists"));
  const auto bad_stitch = testutil::run_panoscan("export prestitched --scan " + scan_dir().string() +
                                                 " --stitch truth --out " + (dir_->path() / "cli-ps").string());
  EXPECT_EQ(bad_stitch.exit_code, 2);
  EXPECT_THAT(bad_stitch.output, HasSubstr("--stitch"));
  const auto bad_poses = testutil::run_panoscan("export colmap --scan " + scan_dir().string() + " --poses " +
                                                (dir_->path() / "no-such-track").string() + " --out " +
                                                (dir_->path() / "cli-colmap").string());
  EXPECT_EQ(bad_poses.exit_code, 2);
  EXPECT_THAT(bad_poses.output, HasSubstr("no-such-track"));
  EXPECT_FALSE(fs::exists(dir_->path() / "cli-colmap"));
}

}  // namespace
}  // namespace panoscan
