// MAP integration (paper §5.2, Table 5): mutual best pairs, union-find, Eq. 11.
#include <cmath>

#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/random.h"
#include "panoscan/recon/integration.h"
#include "panoscan/recon/point_covariance.h"
#include "panoscan/recon/pose_graph.h"
#include "panoscan/recon/registration.h"
#include "panoscan/sim/renderer.h"
#include "test_util.h"

using namespace panoscan;

namespace {

constexpr double kX0 = -2.0, kX1 = 3.0, kY0 = -2.5, kY1 = 2.0, kHeight = 2.7;

// Distance of a point inside the box room to its surface.
double distance_to_room(const Eigen::Vector3d& p) {
  return std::min({std::abs(p.x() - kX0), std::abs(p.x() - kX1), std::abs(p.y() - kY0), std::abs(p.y() - kY1),
                   std::abs(p.z()), std::abs(p.z() - kHeight)});
}

double rmse_to_room(const PointCloud& cloud) {
  double sum = 0;
  for (const auto& p : cloud.positions) sum += std::pow(distance_to_room(p), 2);
  return std::sqrt(sum / cloud.size());
}

// A panorama of the room from `centre` with depth noise of std `sigma` along each ray and the
// covariance of Eq. 9: surface (GICP, from the neighbours) + measurement (half a pixel across
// the ray, sigma along it).
PanoramaPoints render_points(const Renderer& renderer, const Eigen::Vector3d& centre, double sigma,
                             std::uint64_t seed) {
  const Equirectangular pano{128};
  const Rigid3d world_from_panorama = make_rigid(Eigen::Matrix3d::Identity(), centre);
  const RenderedView view = renderer.render_equirectangular(world_from_panorama, pano);
  PanoramaPoints points;
  points.world_from_panorama = world_from_panorama;
  RandomStream rng(seed, 0, 0, RandomPurpose::kGeneric);
  for (int v = 0; v < pano.height; ++v)
    for (int u = 0; u < pano.width(); ++u) {
      const double depth = view.depth.at(u, v);
      if (depth <= 0) continue;
      const double noisy = depth + rng.normal() * sigma;
      points.points.push_back(pano.direction(u, v) * noisy);
      const double phi = 2 * M_PI * (u + 0.5) / pano.width(), theta = M_PI * (v + 0.5) / pano.height;
      points.covariances.push_back(
          equirectangular_point_covariance(phi, theta, noisy, 0.5 * M_PI / pano.height, sigma));
      points.colours.push_back({100, 150, 200});
    }
  // As panorama_integration_points: the metric surface covariance (a position uncertainty).
  RegistrationCloud surface;
  surface.points = points.points;
  SurfaceOptions metric;
  metric.metric_scale = true;
  prepare_surface(surface, Eigen::Vector3d::Zero(), metric);
  for (std::size_t i = 0; i < points.points.size(); ++i) points.covariances[i] += surface.surface_covariances[i];
  return points;
}

}  // namespace

TEST(Integration, MapClosedFormIsTheInformationWeightedMean) {
  PanoramaPoints a, b;
  a.points = {Eigen::Vector3d(0, 0, 1.00)};
  b.points = {Eigen::Vector3d(0.01, 0, 1.02)};
  a.covariances = {Eigen::Vector3d(1e-4, 1e-4, 4e-4).asDiagonal()};
  b.covariances = {Eigen::Vector3d(4e-4, 1e-4, 1e-4).asDiagonal()};
  IntegrationOptions options;
  const IntegrationResult result = integrate_panoramas({a, b}, options);
  ASSERT_EQ(result.cloud.size(), 1u);
  EXPECT_EQ(result.groups, 1u);
  // Per axis: x = (0/1e-4 + 0.01/4e-4) / (1/1e-4 + 1/4e-4) = 0.002; z = (1/4e-4 + 1.02/1e-4) / (...) = 1.016.
  EXPECT_NEAR(result.cloud.positions[0].x(), 0.002, 1e-12);
  EXPECT_NEAR(result.cloud.positions[0].z(), 1.016, 1e-12);
  // The fused variance: (1e-4 || 4e-4) = 0.8e-4 on x and z, 0.5e-4 on y -> trace / 3.
  EXPECT_NEAR(result.cloud.variances[0], (0.8e-4 + 0.5e-4 + 0.8e-4) / 3, 1e-10);
  // The paper's printed form (inverse square roots) weights differently.
  options.weighting = MapWeighting::kPaperInverseSqrt;
  const IntegrationResult paper = integrate_panoramas({a, b}, options);
  EXPECT_NEAR(paper.cloud.positions[0].x(), (0.0 / 0.01 + 0.01 / 0.02) / (1 / 0.01 + 1 / 0.02), 1e-12);
  // Average: the midpoint.
  options.method = MergeMethod::kAverage;
  EXPECT_NEAR(integrate_panoramas({a, b}, options).cloud.positions[0].z(), 1.01, 1e-12);
  options.method = MergeMethod::kAlignOnly;
  EXPECT_EQ(integrate_panoramas({a, b}, options).cloud.size(), 2u);
}

TEST(Integration, UnionFindGroupsAcrossThreePanoramas) {
  // The same surface point seen by three panoramas: one group of three.
  PanoramaPoints a, b, c;
  for (auto* p : {&a, &b, &c}) p->covariances = {Eigen::Matrix3d::Identity() * 1e-4};
  a.points = {Eigen::Vector3d(0, 0, 1)};
  b.points = {Eigen::Vector3d(0, 0, 1.01)};
  c.world_from_panorama = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0));
  c.points = {Eigen::Vector3d(-1, 0, 0.99)};
  const IntegrationResult result = integrate_panoramas({a, b, c}, IntegrationOptions{});
  EXPECT_EQ(result.cloud.size(), 1u);
  EXPECT_EQ(result.grouped_points, 3u);
  EXPECT_NEAR(result.cloud.positions[0].z(), 1.0, 1e-12);
}

TEST(Integration, Table5OrderingAlignAverageMap) {
  // Two panoramas of one room, one much noisier than the other. On the merged points, averaging
  // beats keeping the noisy observation, and MAP (which trusts the precise one across the
  // surface) beats averaging.
  const Scene scene = testutil::make_box_room(kX0, kX1, kY0, kY1, kHeight, Eigen::Vector3d::Zero());
  const Renderer renderer(scene);
  const PanoramaPoints precise = render_points(renderer, Eigen::Vector3d(0.0, 0.0, 1.2), 0.003, 1);
  const PanoramaPoints noisy = render_points(renderer, Eigen::Vector3d(0.6, 0.3, 1.2), 0.02, 2);
  IntegrationOptions options;
  options.method = MergeMethod::kAlignOnly;
  const IntegrationResult align = integrate_panoramas({precise, noisy}, options);
  options.method = MergeMethod::kAverage;
  const IntegrationResult average = integrate_panoramas({precise, noisy}, options);
  options.method = MergeMethod::kMap;
  const IntegrationResult map = integrate_panoramas({precise, noisy}, options);
  auto merged_rmse = [](const IntegrationResult& r) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < r.cloud.size(); ++i)
      if (r.observations[i] > 1) {
        sum += std::pow(distance_to_room(r.cloud.positions[i]), 2);
        ++n;
      }
    return std::sqrt(sum / n);
  };
  PointCloud noisy_alone;
  for (const auto& p : noisy.points) noisy_alone.positions.push_back(noisy.world_from_panorama * p);
  const double rmse_noisy = rmse_to_room(noisy_alone), rmse_average = merged_rmse(average), rmse_map = merged_rmse(map);
  std::printf(
      "all points: align only %.2f mm, + average %.2f mm, + MAP %.2f mm; merged points: noisy panorama %.2f mm, "
      "average %.2f mm, MAP %.2f mm (%zu groups of %zu points)\n",
      rmse_to_room(align.cloud) * 1e3, rmse_to_room(average.cloud) * 1e3, rmse_to_room(map.cloud) * 1e3,
      rmse_noisy * 1e3, rmse_average * 1e3, rmse_map * 1e3, map.groups, map.input_points);
  EXPECT_GT(map.groups, map.input_points / 10);
  EXPECT_LT(rmse_average, rmse_noisy);
  EXPECT_LT(rmse_map, 0.8 * rmse_average);
  EXPECT_LT(rmse_to_room(map.cloud), rmse_to_room(average.cloud));
  EXPECT_EQ(map.cloud.size(), map.input_points - map.grouped_points + map.groups);
  EXPECT_EQ(align.cloud.size(), align.input_points);
  // Colours survive merging.
  ASSERT_TRUE(map.cloud.has_colours());
  EXPECT_EQ(map.cloud.colours[0][1], 150);
  // Deterministic with any thread count.
  options.threads = 1;
  const IntegrationResult one = integrate_panoramas({precise, noisy}, options);
  options.threads = 2;
  const IntegrationResult two = integrate_panoramas({precise, noisy}, options);
  ASSERT_EQ(one.cloud.size(), two.cloud.size());
  EXPECT_EQ(one.cloud.positions, two.cloud.positions);
}

TEST(Integration, BadInputIsAClearError) {
  EXPECT_THROW(integrate_panoramas({}, IntegrationOptions{}), Error);
  PanoramaPoints no_covariances;
  no_covariances.points = {Eigen::Vector3d(0, 0, 1)};
  EXPECT_THROW(integrate_panoramas({no_covariances, no_covariances}, IntegrationOptions{}), Error);
  IntegrationOptions average;
  average.method = MergeMethod::kAverage;
  EXPECT_NO_THROW(integrate_panoramas({no_covariances, no_covariances}, average));
  PanoramaPoints nan_point = no_covariances;
  nan_point.points[0].x() = std::nan("");
  EXPECT_THROW(integrate_panoramas({nan_point}, average), Error);
  EXPECT_THROW(merge_method_from_string("median"), Error);
}

TEST(PoseGraph, RedundantNoisyEdgesImproveOnChainingThem) {
  // Four panoramas (as SO-1..4), all six pairwise registrations with errors of ~0.5 deg / 1 cm.
  const std::vector<Rigid3d> truth = {make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0)),
                                      make_rigid(so3_exp(Eigen::Vector3d(0, 0, 1.5)), Eigen::Vector3d(2.0, 1.6, 0.01)),
                                      make_rigid(so3_exp(Eigen::Vector3d(0, 0, 3.1)), Eigen::Vector3d(0.0, 1.6, -0.01)),
                                      make_rigid(so3_exp(Eigen::Vector3d(0, 0, -1.6)), Eigen::Vector3d(2.0, 0.0, 0.0))};
  RandomStream rng(4, 0, 0, RandomPurpose::kGeneric);
  std::vector<PoseGraphEdge> edges;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      const Eigen::Vector3d rotation_noise(rng.normal(), rng.normal(), rng.normal());
      const Eigen::Vector3d translation_noise(rng.normal(), rng.normal(), rng.normal());
      const Rigid3d noise = make_rigid(so3_exp(rotation_noise * deg2rad(0.5)), translation_noise * 0.01);
      edges.push_back({a, b, truth[b].inverse() * truth[a] * noise});
    }
  // Initial poses: chained along 0 -> 1 -> 3 -> 2 (errors accumulate).
  std::vector<Rigid3d> initial(4);
  initial[0] = truth[0];
  auto edge = [&](int a, int b) {
    for (const auto& e : edges)
      if (e.from == a && e.to == b) return e.to_from_from;
    return Rigid3d::Identity();
  };
  initial[1] = initial[0] * edge(0, 1).inverse();
  initial[3] = initial[1] * edge(1, 3).inverse();
  initial[2] = initial[3] * edge(2, 3);
  auto total_error = [&](const std::vector<Rigid3d>& poses) {
    double sum = 0;
    for (int i = 0; i < 4; ++i) sum += (poses[i].translation() - truth[i].translation()).squaredNorm();
    return std::sqrt(sum / 4);
  };
  const PoseGraphResult result = optimize_pose_graph(initial, edges, PoseGraphOptions{});
  std::printf("pose graph: RMS position error %.1f mm chained, %.1f mm optimised (cost %.3g -> %.3g)\n",
              total_error(initial) * 1e3, total_error(result.world_from_node) * 1e3, result.initial_cost,
              result.final_cost);
  EXPECT_TRUE(result.converged);
  EXPECT_LT(result.final_cost, result.initial_cost);
  EXPECT_LT(total_error(result.world_from_node), 0.8 * total_error(initial));
  EXPECT_EQ(result.world_from_node[0].matrix(), truth[0].matrix());  // the gauge stays fixed
  // A node without edges cannot be placed: an error, not a silent guess.
  std::vector<Rigid3d> five = initial;
  five.push_back(Rigid3d::Identity());
  EXPECT_THROW(optimize_pose_graph(five, edges, PoseGraphOptions{}), Error);
}
