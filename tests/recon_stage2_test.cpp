// Stage 2 (paper §5) on panoramas with known noise: pair registration (ORB guess, GICP with the
// measured variance, verification by the features) and integration into one cloud.
#include <cmath>

#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/random.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/recon/stage2.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/renderer.h"

using namespace panoscan;

namespace {

// A fused panorama as stage 1 would produce it, from a noiseless render: depth with noise of
// the Handa model's std at that depth (and 3x more on the left quarter, as a noisy region),
// the variance of that noise and 8 observations per pixel.
Panorama synthetic_panorama(const Renderer& renderer, const Rigid3d& world_from_pano, int height, std::uint64_t seed) {
  Panorama p;
  p.pano = Equirectangular{height};
  p.world_from_pano = world_from_pano;
  const RenderedView view = renderer.render_equirectangular(world_from_pano, p.pano);
  const int width = p.pano.width();
  p.colour = ImageF32(width, height, 3, 0.f);
  p.depth = ImageF32(width, height, 1, 0.f);
  p.variance = ImageF32(width, height, 1, 0.f);
  p.count = ImageF32(width, height, 1, 0.f);
  p.flagged = ImageU8(width, height, 1, 0);
  RandomStream rng(seed, 0, 0, RandomPurpose::kGeneric);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      for (int c = 0; c < 3; ++c) p.colour.at(u, v, c) = view.rgb.at(u, v, c) / 255.f;
      const double z = view.depth.at(u, v);
      if (z <= 0.5) continue;
      // A fused pixel averages ~8 measurements: its error std is the model's / sqrt(8).
      const double sigma = (u < width / 4 ? 3.0 : 1.0) * 9.49e-4 * z * z / std::sqrt(8.0);
      p.depth.at(u, v) = float(z + rng.normal() * sigma);
      p.variance.at(u, v) = float(8.0 * sigma * sigma);  // the spread of the measurements
      p.count.at(u, v) = 8.f;
    }
  p.method = "synthetic";
  return p;
}

Rigid3d pose_at(const Scene& scene, int position, double yaw) {
  return make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                    scene.positions[position].floor_point + Eigen::Vector3d(0, 0, 1.1));
}

}  // namespace

TEST(Stage2, RegistersTwoOfficePanoramasAndRejectsAWrongGivenPose) {
  const Scene scene = scenes::make_builtin_scene("office");
  const Renderer renderer(scene);
  const Rigid3d world_from_target = pose_at(scene, 0, 0.0), world_from_source = pose_at(scene, 2, deg2rad(-25));
  const Panorama target = synthetic_panorama(renderer, world_from_target, 320, 1);
  const Panorama source = synthetic_panorama(renderer, world_from_source, 320, 2);
  const Rigid3d truth = world_from_target.inverse() * world_from_source;
  PairRegistrationOptions options;
  options.cloud.pixel_stride = 2;
  const PairRegistration result = register_panorama_pair(source, target, options, nullptr, "SO-3", "SO-1");
  const double rotation_error = rad2deg(rotation_angle(result.target_from_source.linear().transpose() * truth.linear()));
  const double translation_error = (result.target_from_source.translation() - truth.translation()).norm();
  std::printf("SO-3 -> SO-1: %d ORB inliers, %d consistent; error %.3f deg, %.1f mm after %d GICP iterations\n",
              result.guess.inliers, result.consistent_matches, rotation_error, translation_error * 1e3,
              result.icp.iterations);
  EXPECT_LT(rotation_error, 0.1);
  EXPECT_LT(translation_error, 0.005);

  // A given initial pose that is 90 degrees wrong fails loudly.
  const Rigid3d wrong = make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
                                   Eigen::Vector3d::Zero()) * truth;
  try {
    register_panorama_pair(source, target, options, &wrong, "SO-3", "SO-1");
    FAIL() << "a 90 degree wrong initial pose was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("SO-3 -> SO-1"), std::string::npos) << e.what();
  }
}

TEST(Stage2, IntegrationWithMapBeatsAlignOnlyAgainstTheMesh) {
  const Scene scene = scenes::make_builtin_scene("office");
  const Renderer renderer(scene);
  const Rigid3d world_from_a = pose_at(scene, 0, 0.0), world_from_b = pose_at(scene, 2, 0.4);
  const Panorama a = synthetic_panorama(renderer, world_from_a, 256, 3);
  const Panorama b = synthetic_panorama(renderer, world_from_b, 256, 4);
  PanoramaCloudOptions cloud_options;
  const std::vector<PanoramaPoints> points = {panorama_integration_points(a, world_from_a, cloud_options),
                                              panorama_integration_points(b, world_from_b, cloud_options)};
  const eval::MeshDistance mesh(scene.mesh, "office");
  auto rmse = [&](const PointCloud& cloud) {
    const std::vector<double> d = mesh.distances(cloud.positions);
    double sum = 0;
    for (double x : d) sum += x * x;
    return std::sqrt(sum / d.size());
  };
  IntegrationOptions options;
  options.method = MergeMethod::kAlignOnly;
  const double align = rmse(integrate_panoramas(points, options).cloud);
  options.method = MergeMethod::kAverage;
  const double average = rmse(integrate_panoramas(points, options).cloud);
  options.method = MergeMethod::kMap;
  const IntegrationResult map_result = integrate_panoramas(points, options);
  const double map = rmse(map_result.cloud);
  std::printf("office SO-1 + SO-3 (true poses): align only %.2f mm, + average %.2f mm, + MAP %.2f mm (%zu groups)\n",
              align * 1e3, average * 1e3, map * 1e3, map_result.groups);
  EXPECT_LT(average, align);
  EXPECT_LT(map, average);
}
