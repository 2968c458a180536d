// The renderer and the simulator: exact ground truth, determinism, bad input.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/scan.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

using namespace panoscan;
namespace fs = std::filesystem;

namespace {

SimOptions small_options() {
  SimOptions options;
  options.rig.width = 80;
  options.rig.height = 60;
  options.output.every = 90;  // 11 frames per camera over the whole turn
  options.seed = 21;
  return options;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(Renderer, DepthIsZAlongTheOpticalAxisAndIdsAreTheHitTriangles) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  const Renderer renderer(scene);
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(64, 48);
  const Rigid3d pose = make_rigid(so3_exp(Eigen::Vector3d(1.4, 0.3, -0.5)), Eigen::Vector3d(0.3, 0.2, 1.2));
  const RenderedView view = renderer.render(pose, k);
  int checked = 0;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const int id = view.triangle_id.at(x, y);
      ASSERT_GE(id, 0) << "closed room: every ray hits";
      const Eigen::Vector3d point = pose * k.backproject(x, y, view.depth.at(x, y));
      const auto& tri = scene.mesh.triangles[id];
      const auto& v = scene.mesh.vertices;
      const double d =
          point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(), v[tri[2]].cast<double>());
      ASSERT_LT(d, 1e-4) << "pixel " << x << "," << y;
      ++checked;
    }
  EXPECT_EQ(checked, 64 * 48);
}

TEST(Renderer, EquirectangularDepthIsRadialAndLandsOnTheMesh) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  const Renderer renderer(scene);
  const Equirectangular pano{32};
  const Rigid3d world_from_pano =
      make_rigid(so3_exp(Eigen::Vector3d(0.02, -0.01, 0.7)), Eigen::Vector3d(0.3, 0.2, 1.2));
  const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
  for (int y = 0; y < pano.height; ++y)
    for (int x = 0; x < pano.width(); ++x) {
      const int id = view.triangle_id.at(x, y);
      ASSERT_GE(id, 0);
      const Eigen::Vector3d point = world_from_pano * (pano.direction(x, y) * view.depth.at(x, y));
      const auto& tri = scene.mesh.triangles[id];
      const auto& v = scene.mesh.vertices;
      ASSERT_LT(
          point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(), v[tri[2]].cast<double>()),
          1e-4);
    }
  // Straight up from 1.2 m in a 2.7 m room: the ceiling is 1.5 m away (nearly; the pano is tilted 1 deg).
  EXPECT_NEAR(view.depth.at(0, 0), 1.5, 0.01);
}

TEST(Simulator, NoiselessFramesBackProjectOntoTheMesh) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  SimOptions options = small_options();
  const Simulator sim(scene, 0, options);
  for (int c = 0; c < 3; ++c) {
    const SimulatedFrame frame = sim.render_frame(sim.schedule()[c][3]);
    const PinholeIntrinsics& k = sim.rig().intrinsics;
    std::size_t valid = 0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        const float z = frame.clean_depth.at(x, y);
        if (z <= 0) continue;
        ++valid;
        const Eigen::Vector3d point = frame.world_from_cam * k.backproject(x, y, z);
        const auto& tri = scene.mesh.triangles[frame.triangle_id.at(x, y)];
        const auto& v = scene.mesh.vertices;
        ASSERT_LT(point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(),
                                          v[tri[2]].cast<double>()),
                  1e-4);
      }
    EXPECT_GT(valid, std::size_t(k.width * k.height / 2));
  }
}

TEST(Simulator, SameSeedSameBytesWithOneAndTwoThreads) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  testutil::TempDir tmp("determinism");
  SimOptions options = small_options();
  options.output.clean_depth = true;
  options.threads = 1;
  Simulator(scene, 0, options).write_scan(tmp / "one", false);
  options.threads = 2;
  Simulator(scene, 0, options).write_scan(tmp / "two", false);
  options.seed = 22;
  Simulator(scene, 0, options).write_scan(tmp / "other_seed", false);
  std::size_t files = 0, differing_from_other_seed = 0;
  for (const auto& entry : fs::recursive_directory_iterator(tmp / "one")) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), tmp / "one");
    ASSERT_TRUE(fs::exists(tmp / "two" / relative)) << relative;
    ASSERT_EQ(read_bytes(entry.path()), read_bytes(tmp / "two" / relative)) << relative;
    ++files;
    if (!fs::exists(tmp / "other_seed" / relative) ||
        read_bytes(entry.path()) != read_bytes(tmp / "other_seed" / relative))
      ++differing_from_other_seed;
  }
  EXPECT_GT(files, 60u);
  EXPECT_GT(differing_from_other_seed, files / 2);
}

TEST(Simulator, WrittenScanReadsBackWithGroundTruth) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  testutil::TempDir tmp("readback");
  SimOptions options = small_options();
  options.output.clean_depth = true;
  const Simulator sim(scene, 0, options);
  sim.write_scan(tmp / "scan", false);
  const ScanIndex scan = read_scan_index(tmp / "scan");
  ASSERT_EQ(scan.rig.sensors.size(), 3u);
  EXPECT_EQ(scan.rig.reference_sensor, 1);
  for (int c = 0; c < 3; ++c) {
    ASSERT_EQ(scan.frames[c].size(), sim.schedule()[c].size());
    const auto truth = read_groundtruth_trajectory(tmp / "scan", c);
    ASSERT_EQ(truth.size(), scan.frames[c].size());
    // Calibrated extrinsics differ from the truth by the configured error.
    const Rigid3d error = sim.rig().ref_from_cam_true[c].inverse() * scan.rig.sensors[c].ref_from_cam;
    if (c != 1) {
      EXPECT_NEAR(rad2deg(rotation_angle(error.linear())), 0.5, 1e-6);
      EXPECT_NEAR(error.translation().norm(), 0.005, 1e-6);
    }
    // Noiseless depth from disk back-projects onto the mesh within the PNG step (0.2 mm).
    const RgbdFrame frame = load_frame(scan, c, 2);
    EXPECT_EQ(frame.timestamp, truth[2].timestamp);
    const ImageF32 clean =
        depth_from_png_units(read_png16(tmp / "scan" / "groundtruth" / "depth_clean" / scan.rig.sensors[c].name /
                                        (format_timestamp(truth[2].timestamp) + ".png")),
                             5000.0);
    const PinholeIntrinsics& k = scan.rig.sensors[c].intrinsics;
    std::size_t valid = 0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        const float z = clean.at(x, y);
        if (z <= 0) continue;
        ++valid;
        const Eigen::Vector3d p = truth[2].world_from_cam * k.backproject(x, y, z);
        double best = 1e9;
        for (const auto& tri : scene.mesh.triangles)
          best = std::min(best, point_triangle_distance(p, scene.mesh.vertices[tri[0]].cast<double>(),
                                                        scene.mesh.vertices[tri[1]].cast<double>(),
                                                        scene.mesh.vertices[tri[2]].cast<double>()));
        // The PNG stores z in steps of 0.2 mm: at most 0.1 mm along z, i.e. 0.1 mm x |ray|.
        ASSERT_LT(best, 1e-4 * k.backproject(x, y, 1.0).norm() + 1e-6);
      }
    EXPECT_GT(valid, 1000u);
  }
}

TEST(Simulator, BadInputIsAClearError) {
  Scene empty = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  empty.mesh.triangles.clear();
  empty.mesh.triangle_material.clear();
  empty.mesh.corner_uvs.clear();
  try {
    Simulator sim(empty, 0, small_options());
    FAIL() << "a scene without triangles was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no triangles"), std::string::npos) << e.what();
  }
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  EXPECT_THROW(Simulator(scene, 1, small_options()), Error);
  SimOptions bad = small_options();
  bad.shutter.fps = -30;
  try {
    Simulator sim(scene, 0, bad);
    FAIL() << "a negative frame rate was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shutter.fps"), std::string::npos) << e.what();
  }
  // An unwritable output folder (a path below a regular file) fails and leaves nothing behind.
  testutil::TempDir tmp("unwritable");
  { std::ofstream(tmp / "file") << "x"; }
  const Simulator sim(scene, 0, small_options());
  EXPECT_THROW(sim.write_scan(tmp / "file" / "scan", false), Error);
  std::size_t entries = 0;
  for (auto it = fs::directory_iterator(tmp.path()); it != fs::directory_iterator(); ++it) ++entries;
  EXPECT_EQ(entries, 1u);
}
