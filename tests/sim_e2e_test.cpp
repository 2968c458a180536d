// End to end on the built-in scenes: a small scan written to disk and read back, exact ground
// truth against the exported mesh, and enough ORB features for tracking.
#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "panoscan/core/image_io.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/random.h"
#include "panoscan/core/scan.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

using namespace panoscan;

TEST(SimEndToEnd, OfficeScanOnDiskHasExactGroundTruth) {
  const Scene scene = scenes::make_builtin_scene("office");
  SimOptions options;
  options.rig.width = 160;
  options.rig.height = 120;
  options.output.every = 30;  // ~33 frames per camera over the full turn
  options.output.clean_depth = true;
  options.seed = 3;
  testutil::TempDir tmp("e2e");
  const Simulator sim(scene, 0, options);
  const std::size_t written = sim.write_scan(tmp / "SO-1", false);
  EXPECT_GT(written, 90u);

  const ScanIndex scan = read_scan_index(tmp / "SO-1");
  const TriangleMesh mesh = read_ply_mesh(tmp / "SO-1" / "groundtruth" / "mesh.ply");
  ASSERT_EQ(mesh.triangles.size(), scene.mesh.triangles.size());
  RandomStream rng(1, 0, 0, RandomPurpose::kGeneric);
  for (int c = 0; c < 3; ++c) {
    const auto truth = read_groundtruth_trajectory(tmp / "SO-1", c);
    ASSERT_EQ(truth.size(), scan.frames[c].size());
    const std::size_t f = truth.size() / 2;
    const RgbdFrame frame = load_frame(scan, c, f);
    const PinholeIntrinsics& k = scan.rig.sensors[c].intrinsics;
    const ImageF32 clean =
        depth_from_png_units(read_png16(tmp / "SO-1" / "groundtruth" / "depth_clean" / scan.rig.sensors[c].name /
                                        (format_timestamp(truth[f].timestamp) + ".png")),
                             5000.0);
    // Brute force over all triangles for a random sample of pixels: an independent check of
    // the renderer, the poses and the file formats.
    int checked = 0;
    double noisy_error_sum = 0;
    int noisy_count = 0;
    for (int trial = 0; trial < 400 && checked < 40; ++trial) {
      const int x = rng.uniform_int(0, k.width - 1), y = rng.uniform_int(0, k.height - 1);
      const float z = clean.at(x, y);
      if (z <= 0) continue;
      const Eigen::Vector3d p = truth[f].world_from_cam * k.backproject(x, y, z);
      double best = 1e9;
      for (const auto& tri : mesh.triangles)
        best = std::min(
            best, point_triangle_distance(p, mesh.vertices[tri[0]].cast<double>(), mesh.vertices[tri[1]].cast<double>(),
                                          mesh.vertices[tri[2]].cast<double>()));
      ASSERT_LT(best, 1e-4 * k.backproject(x, y, 1.0).norm() + 1e-6) << "camera " << c << " pixel " << x << "," << y;
      ++checked;
      if (frame.depth.at(x, y) > 0) {
        noisy_error_sum += std::abs(frame.depth.at(x, y) - z);
        ++noisy_count;
      }
    }
    EXPECT_GE(checked, 30);
    // The stored depth is the noisy one: it differs from the truth, by millimetres.
    ASSERT_GT(noisy_count, 10);
    EXPECT_GT(noisy_error_sum / noisy_count, 1e-4);
    EXPECT_LT(noisy_error_sum / noisy_count, 0.05);
  }
}

TEST(SimEndToEnd, BuiltinScenesGiveEnoughOrbFeaturesFromTheScanningPositions) {
  // The tracking front end needs texture, but at the default ICL-NUIM density not everywhere: over
  // views all around each scanning position and all three cameras, ORB (OpenCV defaults, 640x480)
  // finds on average >= 200 keypoints per view, and some views, of plain wall or ceiling, have
  // almost none (the frames Eq. 2-3 carry). The rich density averages >= 300.
  cv::Ptr<cv::ORB> orb = cv::ORB::create();
  // The default detector keeps at most 500 features; an uncapped one shows the texture's margin.
  cv::Ptr<cv::ORB> uncapped = cv::ORB::create(100000);
  for (const std::string& name : scenes::builtin_scene_names())
    for (const scenes::TextureDensity density : {scenes::TextureDensity::kIcl, scenes::TextureDensity::kRich}) {
      const Scene scene = scenes::make_builtin_scene(name, scenes::SceneStyle{density});
      SimOptions options;
      options.noise.preset = NoisePreset::kNone;
      double total = 0, total_uncapped = 0;
      int views = 0, poorest = 1 << 30;
      for (std::size_t position = 0; position < scene.positions.size(); ++position) {
        const Simulator sim(scene, int(position), options);
        for (int c = 0; c < 3; ++c) {
          const auto& frames = sim.schedule()[c];
          for (int step = 0; step < 8; ++step) {
            const SimulatedFrame frame = sim.render_frame(frames[step * frames.size() / 8]);
            cv::Mat rgb(frame.rgb.height, frame.rgb.width, CV_8UC3, const_cast<std::uint8_t*>(frame.rgb.data.data()));
            cv::Mat grey;
            cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
            std::vector<cv::KeyPoint> keypoints;
            orb->detect(grey, keypoints);
            total += keypoints.size();
            std::vector<cv::KeyPoint> all_keypoints;
            uncapped->detect(grey, all_keypoints);
            total_uncapped += all_keypoints.size();
            poorest = std::min<int>(poorest, int(keypoints.size()));
            ++views;
          }
        }
      }
      const double mean = total / views;
      const std::string label = name + (density == scenes::TextureDensity::kIcl ? " (icl)" : " (rich)");
      RecordProperty(name + (density == scenes::TextureDensity::kIcl ? "_icl" : "_rich") + "_mean_orb_keypoints",
                     std::to_string(mean));
      std::printf("%s: mean %.0f ORB keypoints per view over %d views (poorest %d); uncapped mean %.0f\n",
                  label.c_str(), mean, views, poorest, total_uncapped / views);
      if (density == scenes::TextureDensity::kIcl) {
        EXPECT_GE(mean, 200.0) << label;
        EXPECT_LT(poorest, 50) << label;
      } else {
        EXPECT_GE(mean, 300.0) << label;
      }
    }
}

TEST(SimEndToEnd, APositionThatSeesAlmostNothingIsRefusedNamingIt) {
  // The office with its first position moved 50 m outside the room: a probe of the turn finds
  // (almost) no depth in the sensor's range, so nothing is written and the error names the position.
  testutil::TempDir tmp("sim-outside");
  Scene scene = scenes::make_builtin_scene("office");
  scene.positions[0].floor_point += Eigen::Vector3d(50.0, 0.0, 0.0);
  SimOptions options;
  options.rig.width = 160;
  options.rig.height = 120;
  options.output.every = 32;
  const Simulator outside(scene, 0, options);
  EXPECT_LT(outside.probe_depth_coverage(), 0.2);
  const std::string message = testutil::error_of([&] { outside.write_scan(tmp.path() / "scan", false); });
  EXPECT_NE(message.find(scene.positions[0].name), std::string::npos) << message;
  EXPECT_NE(message.find("sees almost nothing"), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(tmp.path() / "scan"));
  // Inside the room the same probe sees depth nearly everywhere; with the check off the outside
  // scan is written.
  const Scene office = scenes::make_builtin_scene("office");  // the Simulator keeps a reference to its scene
  const Simulator inside(office, 0, options);
  EXPECT_GT(inside.probe_depth_coverage(), 0.8);
  options.output.min_depth_coverage = 0.0;
  EXPECT_GT(Simulator(scene, 0, options).write_scan(tmp.path() / "unchecked", false), 0u);
}
