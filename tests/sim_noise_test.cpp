// The depth noise model of docs/ARCHITECTURE.md §4 (Handa et al. 2014), checked statistically through the
// whole renderer on a real wall.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "panoscan/sim/noise.h"
#include "panoscan/sim/renderer.h"
#include "test_util.h"

using namespace panoscan;

namespace {

struct WallStatistics {
  double normalised_std = 0;  // std of (noisy - clean) / predicted sigma
  double absolute_std_m = 0;  // std of (noisy - clean) in metres
  double fraction_on_levels = 0;
  std::size_t valid = 0;
};

// Looks at a large wall from `distance` (camera 4 m above the floor, so only the wall is seen), turned by `yaw_deg` so
// that the depth, and with it the quantisation phase, varies across the image.
WallStatistics measure_wall(double distance, double yaw_deg, const NoiseOptions& options, int frames) {
  const Scene scene = testutil::make_box_room(-distance, 30, -30, 30, 8, Eigen::Vector3d::Zero());
  const Renderer renderer(scene);
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(320, 240);
  // Camera looking along -x at the wall x = -distance.
  Eigen::Matrix3d world_from_cam_rotation;
  world_from_cam_rotation.col(2) = Eigen::Vector3d(-1, 0, 0);
  world_from_cam_rotation.col(0) = Eigen::Vector3d(0, 1, 0);
  world_from_cam_rotation.col(1) = Eigen::Vector3d(0, 0, -1);
  const Rigid3d pose = make_rigid(
      Eigen::Matrix3d(Eigen::AngleAxisd(deg2rad(yaw_deg), Eigen::Vector3d::UnitZ())) * world_from_cam_rotation,
      Eigen::Vector3d(0, 0, 4.0));
  const RenderedView view = renderer.render(pose, k);
  const double sigma_disparity = options.effective_disparity_std();
  WallStatistics stats;
  double sum = 0, sum2 = 0, abs_sum = 0, abs_sum2 = 0;
  std::size_t on_levels = 0;
  for (int frame = 0; frame < frames; ++frame) {
    DepthNoiseInput input{&view.depth, &view.incidence_cos, &k, 0, frame};
    const ImageF32 noisy = apply_depth_noise(input, options, 77);
    for (int y = 8; y < k.height - 8; ++y)
      for (int x = 8; x < k.width - 8; ++x) {
        const double z = noisy.at(x, y), z0 = view.depth.at(x, y);
        if (z <= 0) continue;
        const double e = z - z0;
        const double n = e / disparity_model_depth_std(z0, sigma_disparity);
        sum += n;
        sum2 += n * n;
        abs_sum += e;
        abs_sum2 += e * e;
        ++stats.valid;
        const double level = 351.3 / z;  // must be a whole number of disparity units
        on_levels += std::abs(level - std::round(level)) < 1e-3;
      }
  }
  const double n = double(stats.valid);
  stats.normalised_std = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  stats.absolute_std_m = std::sqrt(abs_sum2 / n - (abs_sum / n) * (abs_sum / n));
  stats.fraction_on_levels = on_levels / n;
  return stats;
}

}  // namespace

TEST(DepthNoise, PredictedStdMatchesTheSpecFigures) {
  EXPECT_NEAR(handa_depth_std(1.0) * 1e3, 0.95, 0.01);
  EXPECT_NEAR(handa_depth_std(2.0) * 1e3, 3.8, 0.02);
  EXPECT_NEAR(handa_depth_std(3.0) * 1e3, 8.54, 0.05);
  EXPECT_NEAR(handa_depth_std(5.0) * 1e3, 23.7, 0.1);
}

TEST(DepthNoise, FlatWallStdIsTheModelsAndDepthsLieOnDisparityLevels) {
  NoiseOptions options;  // handa
  // Turned by 8 deg: enough depth range to cross dozens of disparity levels (averaging over the
  // quantisation phase, as the model's 1/12 does), little enough that the sub-pixel shift on the
  // slope adds only ~3% at 1 m.
  for (double distance : {1.0, 2.0, 4.0}) {
    const WallStatistics stats = measure_wall(distance, 8.0, options, 2);
    ASSERT_GT(stats.valid, 50000u);
    EXPECT_NEAR(stats.normalised_std, 1.0, 0.15) << "wall at " << distance << " m";
    // Absolute std against the formula at the wall's centre distance (within 15%).
    const double predicted = handa_depth_std(distance);
    std::printf("wall at %.0f m: depth std %.2f mm (model %.2f mm), normalised std %.3f\n", distance,
                stats.absolute_std_m * 1e3, predicted * 1e3, stats.normalised_std);
    EXPECT_NEAR(stats.absolute_std_m / predicted, 1.0, 0.15)
        << "wall at " << distance << " m: measured " << stats.absolute_std_m * 1e3 << " mm";
    EXPECT_EQ(stats.fraction_on_levels, 1.0) << "wall at " << distance << " m";
  }
}

TEST(DepthNoise, DisparityNoiseIsGaussianWithTheModelsStd) {
  // Without the sub-pixel shift the only randomness is d + N(0, sigma^2) before rounding, so in
  // disparity units: E[(d_noisy - d)^2] = sigma^2 + 1/12 over the quantisation phase, and the
  // level differs from round(d) with probability E|N| = sigma * sqrt(2 / pi). Quantisation alone
  // (the noise term dropped) gives 1/12 and 0: this test tells them apart; the 15% check above does not.
  const Scene scene = testutil::make_box_room(-2.0, 30, -30, 30, 8, Eigen::Vector3d::Zero());
  const Renderer renderer(scene);
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(320, 240);
  Eigen::Matrix3d rotation;
  rotation.col(2) = Eigen::Vector3d(-1, 0, 0);
  rotation.col(0) = Eigen::Vector3d(0, 1, 0);
  rotation.col(1) = Eigen::Vector3d(0, 0, -1);
  const RenderedView view =
      renderer.render(make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(deg2rad(15.0), Eigen::Vector3d::UnitZ())) * rotation,
                                 Eigen::Vector3d(0, 0, 4.0)),
                      k);
  NoiseOptions options;
  options.shift_std_px = 0.0;
  double sum2 = 0;
  std::size_t n = 0, changed = 0;
  for (int frame = 0; frame < 3; ++frame) {
    DepthNoiseInput input{&view.depth, &view.incidence_cos, &k, 0, frame};
    const ImageF32 noisy = apply_depth_noise(input, options, 13);
    for (std::size_t i = 0; i < noisy.data.size(); ++i) {
      if (noisy.data[i] <= 0) continue;
      const double d_clean = 351.3 / view.depth.data[i];
      const double d_noisy = 351.3 / noisy.data[i];
      sum2 += (d_noisy - d_clean) * (d_noisy - d_clean);
      changed += std::lround(d_noisy) != std::lround(std::floor(d_clean + 0.5));
      ++n;
    }
  }
  ASSERT_GT(n, 100000u);
  EXPECT_NEAR(std::sqrt(sum2 / n), std::sqrt(1.0 / 36 + 1.0 / 12), 0.01);
  EXPECT_NEAR(double(changed) / n, (1.0 / 6) * std::sqrt(2 / M_PI), 0.01);
}

TEST(DepthNoise, KinectPresetIsAboutTwiceAsNoisy) {
  NoiseOptions handa, kinect;
  kinect.preset = NoisePreset::kKinect;
  const double s_handa = measure_wall(2.0, 12.0, handa, 1).absolute_std_m;
  const double s_kinect = measure_wall(2.0, 12.0, kinect, 1).absolute_std_m;
  // sqrt(0.25 + 1/12) / sqrt(1/9) = 1.73
  EXPECT_NEAR(s_kinect / s_handa, 1.73, 0.25);
}

TEST(DepthNoise, RangeIncidenceAndInvalidNeighbours) {
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(40, 30);
  ImageF32 depth(40, 30, 1, 2.0f), incidence(40, 30, 1, 1.0f);
  for (int y = 0; y < 30; ++y) {
    // Bands five pixels wide, so that no sub-pixel shift (std 0.5 px) reaches out of them from
    // their inner columns.
    for (int x = 0; x < 5; ++x) depth.at(x, y) = 0.3f;    // too close
    for (int x = 35; x < 40; ++x) depth.at(x, y) = 9.0f;  // too far
    incidence.at(30, y) = 0.1f;                           // 84 deg: grazing
    depth.at(20, y) = 0.0f;                               // a hole: neighbours may become invalid through the shift
  }
  NoiseOptions options;
  DepthNoiseInput input{&depth, &incidence, &k, 0, 0};
  const ImageF32 noisy = apply_depth_noise(input, options, 5);
  int holes_near_gap = 0;
  for (int y = 0; y < 30; ++y) {
    EXPECT_EQ(noisy.at(0, y), 0.f);
    EXPECT_EQ(noisy.at(1, y), 0.f);
    EXPECT_EQ(noisy.at(38, y), 0.f);
    EXPECT_EQ(noisy.at(39, y), 0.f);
    EXPECT_EQ(noisy.at(30, y), 0.f);
    EXPECT_EQ(noisy.at(20, y), 0.f);
    holes_near_gap += (noisy.at(19, y) == 0.f) + (noisy.at(21, y) == 0.f);
    EXPECT_GT(noisy.at(10, y), 0.f);
  }
  EXPECT_GT(holes_near_gap, 0);
  // The noiseless preset keeps the exact depth but still applies the sensor's range.
  options.preset = NoisePreset::kNone;
  const ImageF32 clean = apply_depth_noise(input, options, 5);
  EXPECT_EQ(clean.at(10, 10), 2.0f);
  EXPECT_EQ(clean.at(0, 10), 0.f);
  EXPECT_EQ(clean.at(37, 10), 0.f);
  EXPECT_EQ(clean.at(30, 10), 0.f);
}

TEST(DepthNoise, DeterministicPerSeedFrameAndSensor) {
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(64, 48);
  ImageF32 depth(64, 48, 1, 0.f), incidence(64, 48, 1, 0.9f);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) depth.at(x, y) = float(1.0 + 0.02 * x + 0.01 * y);
  NoiseOptions options;
  DepthNoiseInput input{&depth, &incidence, &k, 1, 3};
  const ImageF32 a = apply_depth_noise(input, options, 5);
  const ImageF32 b = apply_depth_noise(input, options, 5);
  EXPECT_EQ(a.data, b.data);
  EXPECT_NE(a.data, apply_depth_noise(input, options, 6).data);
  input.frame = 4;
  EXPECT_NE(a.data, apply_depth_noise(input, options, 5).data);
}

TEST(DepthNoise, InterferenceSpeckleOnlyInTheOverlapBand) {
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(64, 100);
  ImageF32 depth(64, 100, 1, 2.0f), incidence(64, 100, 1, 1.0f);
  NoiseOptions options;
  options.ir_speckle = true;
  options.ir_band_fraction = 0.1;
  options.ir_dropout = 0.5;
  DepthNoiseInput input{&depth, &incidence, &k, 0, 0};
  input.speckle_top = true;
  const ImageF32 noisy = apply_depth_noise(input, options, 1);
  int band_holes = 0, other_holes = 0;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 64; ++x)
      if (noisy.at(x, y) == 0.f) ++(y < 10 ? band_holes : other_holes);
  EXPECT_NEAR(band_holes / 640.0, 0.5, 0.08);
  EXPECT_EQ(other_holes, 0);
}

// Where the CPU has AVX-512 (AVX2) the Handa model runs eight (four) pixels at a time; each kernel
// must give, bit for bit, the scalar loop's depth (DepthNoiseInput::kernel). The input exercises every branch: no hit,
// out of range, grazing incidence, invalid bilinear neighbours, the speckle band's holes, a width
// that is not a multiple of 4, the border clamp, and depths so near (down to 2 cm, with the range
// opened for it) that their disparity is beyond the 1/q table.
TEST(DepthNoise, VectorisedModelIsBitIdenticalToTheScalarLoop) {
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(83, 61);
  ImageF32 clean(k.width, k.height, 1, 0.f), incidence(k.width, k.height, 1, 0.f);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      float z = 0.02f + 0.11f * float((x * 7 + y * 13) % 97);  // 2 cm .. 10.6 m, with jumps
      if ((x * 31 + y * 17) % 23 == 0) z = 0.f;                // scattered holes
      if (x > 40 && x < 47 && y > 10 && y < 30) z = 0.f;       // a larger hole
      clean.at(x, y) = z;
      incidence.at(x, y) = float(0.05 + 0.95 * ((x * 11 + y * 5) % 41) / 40.0);  // some beyond 82 degrees
    }
  for (const double min_depth : {0.5, 0.01, -1.0}) {
    NoiseOptions options;
    options.min_depth_m = std::max(min_depth, 0.01);
    options.max_depth_m = 9.0;
    options.ir_speckle = true;
    options.ir_band_fraction = 0.2;
    // 2 px reaches the border clamp and the invalid neighbours often, and most of the AVX-512 kernel's
    // blocks look up beyond its row windows; the default 0.5 px (the third pass) keeps nearly all inside.
    options.shift_std_px = min_depth < 0 ? 0.5 : 2.0;
    DepthNoiseInput input;
    input.clean_depth = &clean;
    input.incidence_cos = &incidence;
    input.intrinsics = &k;
    input.sensor = 1;
    input.frame = 7;
    input.speckle_top = true;
    input.speckle_bottom = true;
    input.kernel = DepthNoiseInput::Kernel::kScalar;
    const ImageF32 scalar = apply_depth_noise(input, options, 5);
    for (const auto kernel : {DepthNoiseInput::Kernel::kFastest, DepthNoiseInput::Kernel::kAvx2}) {
      input.kernel = kernel;
      ASSERT_EQ(apply_depth_noise(input, options, 5).data, scalar.data)
          << "min depth " << min_depth << ", kernel " << int(kernel) << ", shift std " << options.shift_std_px;
    }
    const auto valid = std::count_if(scalar.data.begin(), scalar.data.end(), [](float z) { return z > 0.f; });
    EXPECT_GT(valid, k.width * k.height / 5);
    EXPECT_LT(valid, k.width * k.height * 4 / 5);
    if (min_depth > 0 && min_depth < 0.05) {  // depths under 9 cm: disparities past the table
      const auto near =
          std::count_if(scalar.data.begin(), scalar.data.end(), [](float z) { return z > 0.f && z < 0.086f; });
      EXPECT_GT(near, 0);
    }
  }
}
