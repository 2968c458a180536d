// Cloud accuracy and completeness: summary statistics with known values, area-uniform sampling,
// visibility with an analytic shadow, a cloud sampled on the mesh (0 error, full completeness),
// known offsets (exact RMSE) and the outlier cut-off reported beside its figure.

#include <cmath>
#include <limits>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/eval/cloud_metrics.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/eval/point_set_distance.h"
#include "panoscan/eval/surface_sampling.h"

namespace panoscan::eval {
namespace {

using ::testing::HasSubstr;

void add_quad(TriangleMesh& mesh, const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
              const Eigen::Vector3f& d) {
  const int first = int(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), {a, b, c, d});
  mesh.triangles.emplace_back(first, first + 1, first + 2);
  mesh.triangles.emplace_back(first, first + 2, first + 3);
}

// A closed room [0, 4] x [0, 4] x [0, 3] (area 80 m^2).
TriangleMesh room_mesh() {
  TriangleMesh mesh;
  const float X = 4.f, Y = 4.f, Z = 3.f;
  add_quad(mesh, {0, 0, 0}, {X, 0, 0}, {X, Y, 0}, {0, Y, 0});  // floor
  add_quad(mesh, {0, 0, Z}, {0, Y, Z}, {X, Y, Z}, {X, 0, Z});  // ceiling
  add_quad(mesh, {0, 0, 0}, {0, 0, Z}, {X, 0, Z}, {X, 0, 0});  // y = 0
  add_quad(mesh, {0, Y, 0}, {X, Y, 0}, {X, Y, Z}, {0, Y, Z});  // y = 4
  add_quad(mesh, {0, 0, 0}, {0, Y, 0}, {0, Y, Z}, {0, 0, Z});  // x = 0
  add_quad(mesh, {X, 0, 0}, {X, 0, Z}, {X, Y, Z}, {X, Y, 0});  // x = 4
  return mesh;
}

TEST(ErrorStats, KnownValues) {
  const ErrorStats s = summarize_errors({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.p90, 3.7);  // h = 3 * 0.9 = 2.7: 3 + 0.7 * (4 - 3)
  EXPECT_DOUBLE_EQ(s.p99, 3.97);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  const ErrorStats empty = summarize_errors({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_TRUE(std::isnan(empty.rmse));  // never a silent 0
  EXPECT_THROW(summarize_errors({1.0, std::numeric_limits<double>::quiet_NaN()}), Error);

  const Histogram h = make_histogram({0.0, 0.5, 0.99, 1.0, 3.0}, 1.0, 2);
  EXPECT_EQ(h.counts, (std::vector<std::size_t>{1, 2}));
  EXPECT_EQ(h.overflow, 2u);
}

TEST(SurfaceSampling, UniformByAreaOnTheSurfaceAndDeterministic) {
  const TriangleMesh mesh = room_mesh();
  const std::size_t n = 40000;
  const std::vector<SurfaceSample> samples = sample_surface_uniform(mesh, n, 5);
  ASSERT_EQ(samples.size(), n);
  const MeshDistance distance(mesh);
  std::size_t on_floor = 0, on_wall_x4 = 0;
  for (const SurfaceSample& s : samples) {
    ASSERT_LT(distance.distance(s.point), 1e-9);
    on_floor += s.point.z() < 1e-9;
    on_wall_x4 += std::abs(s.point.x() - 4.0) < 1e-9;
  }
  // Expected shares 16/80 and 12/80; binomial std about 0.002.
  EXPECT_NEAR(double(on_floor) / n, 16.0 / 80.0, 0.01);
  EXPECT_NEAR(double(on_wall_x4) / n, 12.0 / 80.0, 0.01);

  std::vector<SurfaceSample> one_thread;
  tbb::task_arena(1).execute([&] { one_thread = sample_surface_uniform(mesh, n, 5); });
  for (std::size_t i = 0; i < n; i += 997) EXPECT_EQ(one_thread[i].point, samples[i].point);
  EXPECT_NE(sample_surface_uniform(mesh, 10, 6)[3].point, samples[3].point);

  // A mask keeps samples on the chosen triangles only.
  std::vector<std::uint8_t> floor_only(mesh.num_triangles(), 0);
  floor_only[0] = floor_only[1] = 1;
  for (const SurfaceSample& s : sample_surface_uniform(mesh, 1000, 5, floor_only)) EXPECT_LT(s.triangle, 2);
  EXPECT_THROW(sample_surface_uniform(mesh, 10, 5, std::vector<std::uint8_t>(3, 1)), Error);
  EXPECT_THROW(sample_surface_uniform(mesh, 10, 5, std::vector<std::uint8_t>(mesh.num_triangles(), 0)), Error);
}

TEST(SurfaceSampling, VisibilityCastsTheAnalyticShadow) {
  // A 1 x 1 m plate at x = 2 facing a viewpoint at x = 1: its shadow on the wall x = 4 (3 m from
  // the viewpoint) is 3 x 3 m. Of 80 + 1 m^2, 9 m^2 are hidden.
  TriangleMesh mesh = room_mesh();
  add_quad(mesh, {2.f, 1.5f, 1.f}, {2.f, 2.5f, 1.f}, {2.f, 2.5f, 2.f}, {2.f, 1.5f, 2.f});
  const MeshDistance distance(mesh);
  const std::vector<SurfaceSample> samples = sample_surface_uniform(mesh, 40000, 9);
  VisibilityOptions options;
  EXPECT_EQ(visible_samples(distance, samples, options), std::vector<std::uint8_t>(samples.size(), 1));
  options.viewpoints = {{1.0, 2.0, 1.5}};
  const std::vector<std::uint8_t> visible = visible_samples(distance, samples, options);
  std::size_t hidden = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector3d& p = samples[i].point;
    const bool in_shadow = std::abs(p.x() - 4.0) < 1e-9 && p.y() > 0.5 && p.y() < 3.5;
    if (std::abs(p.y() - 0.5) > 1e-3 && std::abs(p.y() - 3.5) > 1e-3) {  // away from the shadow's border
      EXPECT_EQ(visible[i], in_shadow ? 0 : 1) << p.transpose();
    }
    hidden += !visible[i];
  }
  EXPECT_NEAR(double(hidden) / samples.size(), 9.0 / 81.0, 0.01);

  // Range: from (1, 2, 1.5) nothing on the wall x = 4 is nearer than 3 m.
  options.max_range_m = 2.9;
  const std::vector<std::uint8_t> near_only = visible_samples(distance, samples, options);
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (std::abs(samples[i].point.x() - 4.0) < 1e-9) {
      EXPECT_EQ(near_only[i], 0);
    }
}

TEST(SurfaceSampling, ElevationLimitHidesThePoles) {
  // From the room's centre at 1.5 m, |elevation| <= 45 deg hides the floor and ceiling discs of
  // radius 1.5 m: 2 * pi * 2.25 m^2 of 80.
  const TriangleMesh mesh = room_mesh();
  const MeshDistance distance(mesh);
  const std::vector<SurfaceSample> samples = sample_surface_uniform(mesh, 40000, 4);
  VisibilityOptions options;
  options.viewpoints = {{2.0, 2.0, 1.5}};
  options.max_abs_elevation_deg = 45.0;
  std::size_t hidden = 0;
  for (std::uint8_t v : visible_samples(distance, samples, options)) hidden += !v;
  EXPECT_NEAR(double(hidden) / samples.size(), 2 * M_PI * 2.25 / 80.0, 0.01);
}

TEST(PointSetDistance, NearestPointIsExact) {
  const std::vector<Eigen::Vector3d> points = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {5, 5, 5}};
  const PointSetDistance index(points);
  long found = -1;
  EXPECT_DOUBLE_EQ(index.nearest({0.9, 0.1, 0.0}, &found), std::sqrt(0.01 + 0.01));
  EXPECT_EQ(found, 1);
  EXPECT_DOUBLE_EQ(index.nearest({5, 5, 8}), 3.0);
  const PointSetDistance empty({});
  EXPECT_TRUE(std::isinf(empty.nearest({0, 0, 0})));
}

TEST(CloudMetrics, CloudSampledOnTheMeshIsPerfect) {
  const TriangleMesh mesh = room_mesh();
  const MeshDistance distance(mesh);
  CloudMetricsOptions options;
  options.completeness.samples_per_m2 = 200.0;
  options.completeness.seed = 21;
  // The cloud is exactly the completeness samples (same count and seed): every distance is 0.
  PointCloud cloud;
  for (const SurfaceSample& s : sample_surface_uniform(mesh, 80 * 200, 21)) cloud.positions.push_back(s.point);
  const CloudMetrics m = evaluate_cloud(distance, cloud, "sampled", options);
  EXPECT_EQ(m.accuracy_m.count, cloud.size());
  EXPECT_LT(m.accuracy_m.rmse, 1e-9);
  EXPECT_LT(m.accuracy_m.max, 1e-9);
  ASSERT_TRUE(m.has_completeness);
  EXPECT_EQ(m.surface_samples, 16000u);
  EXPECT_EQ(m.visible_samples, 16000u);
  EXPECT_NEAR(m.sampled_area_m2, 80.0, 1e-9);
  EXPECT_EQ(m.completeness_m.max, 0.0);
  ASSERT_EQ(m.scores.size(), 3u);
  for (const ThresholdScore& s : m.scores) {
    EXPECT_EQ(s.accuracy, 1.0);
    EXPECT_EQ(s.completeness, 1.0);
    EXPECT_EQ(s.f_score, 1.0);
  }

  // An independent, denser sampling: still on the mesh, and complete at 5 cm.
  PointCloud dense;
  for (const SurfaceSample& s : sample_surface_uniform(mesh, 80 * 4000, 77)) dense.positions.push_back(s.point);
  const CloudMetrics d = evaluate_cloud(distance, dense, "dense", options);
  EXPECT_LT(d.accuracy_m.rmse, 1e-9);
  EXPECT_EQ(d.scores[2].completeness, 1.0);
}

TEST(CloudMetrics, KnownOffsetsGiveTheExactFigures) {
  const TriangleMesh mesh = room_mesh();
  const MeshDistance distance(mesh);
  // Points 1, 2, 3, 4 cm off the floor (inside the room), 30 cm outside the wall x = 4 (an outlier).
  PointCloud cloud;
  cloud.positions = {{1, 1, 0.01}, {2, 1, 0.02}, {3, 1, -0.03}, {1, 3, 0.04}, {4.3, 2, 1.5}};
  CloudMetricsOptions options;
  options.completeness.enabled = false;
  options.outlier_cutoff_m = 0.1;
  std::vector<double> distances;
  const CloudMetrics m = evaluate_cloud(distance, cloud, "offsets", options, &distances);
  EXPECT_NEAR(distances[2], 0.03, 1e-12);
  EXPECT_NEAR(m.accuracy_m.rmse, std::sqrt((1e-4 + 4e-4 + 9e-4 + 16e-4 + 0.09) / 5), 1e-12);
  EXPECT_NEAR(m.accuracy_m.mean, (0.01 + 0.02 + 0.03 + 0.04 + 0.3) / 5, 1e-12);
  EXPECT_NEAR(m.accuracy_m.median, 0.03, 1e-12);
  EXPECT_NEAR(m.accuracy_m.max, 0.3, 1e-12);
  EXPECT_EQ(m.outlier_cutoff_m, 0.1);
  EXPECT_EQ(m.points_beyond_cutoff, 1u);
  EXPECT_NEAR(m.accuracy_within_cutoff_m.rmse, std::sqrt((1e-4 + 4e-4 + 9e-4 + 16e-4) / 4), 1e-12);
  // Accuracy at 1, 2, 5 cm: d < tau, so 0.01 is not within 1 cm.
  EXPECT_DOUBLE_EQ(m.scores[0].accuracy, 0.0);
  EXPECT_DOUBLE_EQ(m.scores[1].accuracy, 0.2);
  EXPECT_DOUBLE_EQ(m.scores[2].accuracy, 0.8);
  EXPECT_TRUE(std::isnan(m.scores[0].completeness));
  EXPECT_FALSE(m.has_completeness);
}

TEST(CloudMetrics, CompletenessCountsOnlyVisibleSurface) {
  // Plate at x = 2 in the room; the cloud covers exactly what a viewpoint at x = 1 can see.
  TriangleMesh mesh = room_mesh();
  add_quad(mesh, {2.f, 1.5f, 1.f}, {2.f, 2.5f, 1.f}, {2.f, 2.5f, 2.f}, {2.f, 1.5f, 2.f});
  const MeshDistance distance(mesh);
  CloudMetricsOptions options;
  options.completeness.samples_per_m2 = 300.0;
  options.completeness.seed = 3;
  options.completeness.visibility.viewpoints = {{1.0, 2.0, 1.5}};
  const std::vector<SurfaceSample> samples = sample_surface_uniform(mesh, 81 * 300, 3);
  const std::vector<std::uint8_t> visible = visible_samples(distance, samples, options.completeness.visibility);
  PointCloud cloud;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (visible[i]) cloud.positions.push_back(samples[i].point);

  const CloudMetrics seen = evaluate_cloud(distance, cloud, "visible part", options);
  EXPECT_EQ(seen.visible_samples, cloud.size());
  EXPECT_NEAR(seen.visible_area_m2, 72.0, 1.0);
  EXPECT_EQ(seen.scores[0].completeness, 1.0);

  options.completeness.visibility.viewpoints.clear();  // the whole surface: the shadow is missing
  const CloudMetrics whole = evaluate_cloud(distance, cloud, "visible part", options);
  EXPECT_NEAR(whole.scores[0].completeness, 72.0 / 81.0, 0.01);
  EXPECT_LT(whole.scores[0].f_score, 1.0);
}

TEST(CloudMetrics, BadInput) {
  const MeshDistance distance(room_mesh());
  CloudMetricsOptions options;
  PointCloud empty;
  try {
    evaluate_cloud(distance, empty, "empty.ply", options);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("empty.ply"));
  }
  PointCloud nan_cloud;
  nan_cloud.positions = {{1, 1, 1}, {std::nan(""), 0, 0}};
  try {
    evaluate_cloud(distance, nan_cloud, "nan.ply", options);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("nan.ply"));
    EXPECT_THAT(e.what(), HasSubstr("point 1"));
  }
  options.thresholds_m = {0.01, -1.0};
  PointCloud one;
  one.positions = {{1, 1, 1}};
  EXPECT_THROW(evaluate_cloud(distance, one, "x", options), Error);
}

}  // namespace
}  // namespace panoscan::eval
