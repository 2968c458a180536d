// Band alignment across cameras (recon/frontend/src/cross_camera.h) on synthetic views: two cameras
// pitched 42 deg apart looking at a textured plane, so the truth of every correspondence is known.
#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "cross_camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/scan.h"

namespace panoscan {
namespace {

using cross_camera::BandCrop;
using cross_camera::CameraChains;
using cross_camera::Relation;

constexpr double kPlaneDistance = 2.5;  // the plane z = 2.5 m in the reference (b) camera's frame

// Value noise on a 2-cm grid of the plane, bilinearly interpolated: texture in both directions.
double texture(double x, double y) {
  auto lattice = [](long i, long j) {
    std::uint64_t h = std::uint64_t(i) * 0x9E3779B97F4A7C15ull ^ std::uint64_t(j) * 0xC2B2AE3D27D4EB4Full;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return double(h % 1000) / 1000.0;
  };
  const double gx = x / 0.02, gy = y / 0.02;
  const long i = long(std::floor(gx)), j = long(std::floor(gy));
  const double fx = gx - i, fy = gy - j;
  const double v = (1 - fy) * ((1 - fx) * lattice(i, j) + fx * lattice(i + 1, j)) +
                   fy * ((1 - fx) * lattice(i, j + 1) + fx * lattice(i + 1, j + 1));
  return 40.0 + 170.0 * v;
}

// The view of the plane from a camera at plane_from_cam (grey in all three channels, depth along z).
RgbdFrame render(const PinholeIntrinsics& in, const Rigid3d& plane_from_cam) {
  RgbdFrame frame;
  frame.rgb = ImageU8(in.width, in.height, 3);
  frame.depth = ImageF32(in.width, in.height, 1);
  for (int v = 0; v < in.height; ++v)
    for (int u = 0; u < in.width; ++u) {
      const Eigen::Vector3d direction = plane_from_cam.linear() * in.backproject(u, v, 1.0);
      const Eigen::Vector3d origin = plane_from_cam.translation();
      if (direction.z() <= 1e-6) continue;
      const double s = (kPlaneDistance - origin.z()) / direction.z();
      const Eigen::Vector3d hit = origin + s * direction;
      const std::uint8_t g = std::uint8_t(std::lround(texture(hit.x(), hit.y())));
      for (int c = 0; c < 3; ++c) frame.rgb.at(u, v, c) = g;
      frame.depth.at(u, v) = float(s);  // direction has z = 1 in the camera: s is the depth
    }
  return frame;
}

struct TwoCameras {
  ScanIndex scan;
  Relation relation;
  BandCrop crop_a, crop_b;
  Rigid3d b_from_a_true;
};

// Camera a (sensor 0) pitched up 42 deg and 6 cm above camera b (sensor 1, the reference); rig.json's
// calibration of a is off by `calibration_error`.
TwoCameras make_cameras(const Eigen::Matrix3d& calibration_error) {
  TwoCameras t;
  PinholeIntrinsics in;
  in.width = 320, in.height = 240, in.fx = in.fy = 285.0, in.cx = 159.5, in.cy = 119.5;
  const Rigid3d ref_from_a_true =
      make_rigid(Eigen::AngleAxisd(deg2rad(42.0), Eigen::Vector3d::UnitX()).matrix(), Eigen::Vector3d(0, -0.06, 0));
  t.b_from_a_true = ref_from_a_true;
  SensorInfo a, b;
  a.name = "cam0", b.name = "cam1";
  a.intrinsics = b.intrinsics = in;
  a.ref_from_cam = make_rigid(calibration_error * ref_from_a_true.linear(), ref_from_a_true.translation());
  t.scan.rig.sensors = {a, b};
  t.scan.rig.reference_sensor = 1;
  const FrontendOptions options;
  const std::vector<Relation> relations = cross_camera::overlapping_relations(t.scan, {1, 1}, options);
  EXPECT_EQ(relations.size(), 1u);
  t.relation = relations.front();
  t.crop_a = cross_camera::make_band_crop(render(in, ref_from_a_true), t.relation, true, options);
  t.crop_b = cross_camera::make_band_crop(render(in, Rigid3d::Identity()), t.relation, false, options);
  return t;
}

TEST(CrossCameraBand, CamerasThatNeverOverlapGetNoRelation) {
  ScanIndex scan;
  SensorInfo up, down;
  up.ref_from_cam =
      make_rigid(Eigen::AngleAxisd(deg2rad(45.0), Eigen::Vector3d::UnitX()).matrix(), Eigen::Vector3d(0, -0.06, 0));
  down.ref_from_cam =
      make_rigid(Eigen::AngleAxisd(deg2rad(-45.0), Eigen::Vector3d::UnitX()).matrix(), Eigen::Vector3d(0, 0.06, 0));
  scan.rig.sensors = {up, down};
  EXPECT_TRUE(cross_camera::overlapping_relations(scan, {1, 1}, FrontendOptions{}).empty());
}

TEST(CrossCameraBand, MatchesLandWhereTheTruthProjectsAndFitTheTrueRotation) {
  // The prediction 0.15 deg off (within band_refine_px); every match must be where the true
  // transform puts the anchor, to a fraction of a pixel, and the pair's fitted rotation close to it.
  const TwoCameras t = make_cameras(Eigen::Matrix3d::Identity());
  const Rigid3d predicted =
      make_rigid(Eigen::AngleAxisd(deg2rad(0.15), Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).matrix(),
                 Eigen::Vector3d::Zero()) *
      t.b_from_a_true;
  const cross_camera::BandPairResult result =
      cross_camera::match_band_pair(t.relation, predicted, t.crop_a, t.crop_b, t.scan, FrontendOptions{});
  ASSERT_GE(result.matches.size(), 10u) << result.anchors << " anchors, " << result.aligned << " aligned";
  const auto& in = t.scan.rig.sensors[0].intrinsics;
  double worst_px = 0;
  for (const cross_camera::BandMatch& m : result.matches) {
    const Eigen::Vector2d truth = in.project(t.b_from_a_true * in.backproject(m.in_a.u, m.in_a.v, m.in_a.depth));
    worst_px = std::max(worst_px, (truth - Eigen::Vector2d(m.in_b.u, m.in_b.v)).norm());
    EXPECT_NEAR(m.in_b.depth, (t.b_from_a_true * in.backproject(m.in_a.u, m.in_a.v, m.in_a.depth)).z(), 0.01);
  }
  EXPECT_LT(worst_px, 0.35);
  const double residual_deg =
      rad2deg(rotation_angle(result.a_from_b.linear() * t.b_from_a_true.linear()));  // (a_from_b)^-1 = b_from_a
  const double predicted_deg = rad2deg(rotation_angle(predicted.linear().transpose() * t.b_from_a_true.linear()));
  EXPECT_LT(residual_deg, 0.05) << "prediction " << predicted_deg << " deg off";
}

TEST(CrossCameraBand, TheFirstSearchFindsTheCalibrationError) {
  // rig.json's calibration of camera a 0.6 deg off: more than the band is high. The first search's
  // correction must take the prediction to within 0.1 deg of the truth.
  const Eigen::Matrix3d error = Eigen::AngleAxisd(deg2rad(0.6), Eigen::Vector3d(1.0, 0.4, -0.3).normalized()).matrix();
  const TwoCameras t = make_cameras(error);
  CameraChains chains;  // one frame per camera at the same instant
  chains.timestamps = {{0.0}, {0.0}};
  chains.chain_of_frame = {{0}, {0}};
  chains.chain_from_frame = {{Rigid3d::Identity()}, {Rigid3d::Identity()}};
  int votes = 0;
  const Eigen::Matrix3d correction = cross_camera::estimate_band_correction(
      t.relation, chains, {{0, 0}}, {&t.crop_a}, {&t.crop_b}, t.scan, FrontendOptions{}, &votes);
  const Eigen::Matrix3d corrected = correction * t.relation.b_from_a_calibrated.linear();
  const double before =
      rad2deg(rotation_angle(t.relation.b_from_a_calibrated.linear().transpose() * t.b_from_a_true.linear()));
  const double after = rad2deg(rotation_angle(corrected.transpose() * t.b_from_a_true.linear()));
  std::printf("calibration %.3f deg off, corrected %.3f deg off (%d votes)\n", before, after, votes);
  EXPECT_GT(votes, 12);
  EXPECT_NEAR(before, 0.6, 1e-6);
  EXPECT_LT(after, 0.1);
}

TEST(CrossCameraBand, ChainMotionIsInterpolatedWithinAChainOnly) {
  // A camera turning at 10 deg/s about its y axis, frames every 0.5 s; frame 3 starts a new chain.
  CameraChains chains;
  chains.timestamps = {{0.0, 0.5, 1.0, 1.5, 2.0}};
  chains.chain_of_frame = {{0, 0, 0, 1, 1}};
  for (int f = 0; f < 5; ++f)
    chains.chain_from_frame.resize(1),
        chains.chain_from_frame[0].push_back(
            make_rigid(Eigen::AngleAxisd(deg2rad(10.0 * 0.5 * (f < 3 ? f : f - 3)), Eigen::Vector3d::UnitY()).matrix(),
                       Eigen::Vector3d::Zero()));
  Rigid3d motion;
  ASSERT_TRUE(chains.motion(0, 0.2, 0.9, &motion));
  EXPECT_NEAR(rad2deg(rotation_angle(motion.linear())), 7.0, 1e-9);
  EXPECT_FALSE(chains.motion(0, 0.9, 1.2, &motion));   // between frames 2 and 3: two chains
  EXPECT_FALSE(chains.motion(0, -0.1, 0.4, &motion));  // before the first frame
  ASSERT_TRUE(chains.motion(0, 1.5, 1.75, &motion));
  EXPECT_NEAR(rad2deg(rotation_angle(motion.linear())), 2.5, 1e-9);
}

}  // namespace
}  // namespace panoscan
