// Exact point-to-mesh distances: analytic cases on a box (outside, inside, near edges and
// corners, on the surface), agreement with a brute-force search over all triangles on random
// points around a non-trivial mesh, and bad input.

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/eval/mesh_distance.h"

namespace panoscan::eval {
namespace {

using ::testing::HasSubstr;

// Closed axis-aligned box [0, 2] x [0, 1] x [0, 1.5] (all corners exact in float).
TriangleMesh box_mesh(const Eigen::Vector3f& lo = {0.f, 0.f, 0.f}, const Eigen::Vector3f& hi = {2.f, 1.f, 1.5f}) {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i)
    mesh.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.triangles.emplace_back(q[0], q[1], q[2]);
    mesh.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return mesh;
}

struct KnownDistance {
  Eigen::Vector3d point;
  double distance;
  const char* where;
};

std::vector<KnownDistance> box_cases() {
  return {
      {{1.0, 0.5, 1.8}, 0.3, "above the top face"},
      {{2.25, 0.5, 0.7}, 0.25, "beside the +x face"},
      {{1.0, 0.5, 1.6}, 0.1, "above the top face's diagonal (shared edge of two triangles)"},
      {{2.3, 0.5, 1.9}, 0.5, "outside the edge x=2, z=1.5 (3-4-5)"},
      {{-0.1, -0.2, -0.2}, 0.3, "outside the corner (0, 0, 0)"},
      {{2.0 + 2.0 / 7.0, 1.0 + 3.0 / 7.0, 1.5 + 6.0 / 7.0}, 1.0, "outside the corner (2, 1, 1.5)"},
      {{1.0, 0.5, 0.75}, 0.5, "centre (inside)"},
      {{0.2, 0.5, 0.75}, 0.2, "inside, near the -x face"},
      {{0.1, 0.05, 0.2}, 0.05, "inside, near the corner (0, 0, 0)"},
      {{1.0, 0.0, 0.3}, 0.0, "on the -y face"},
      {{2.0, 1.0, 0.4}, 0.0, "on the edge x=2, y=1"},
      {{0.0, 0.0, 1.5}, 0.0, "on a corner"},
  };
}

TEST(MeshDistance, ExactDistancesToABox) {
  const TriangleMesh mesh = box_mesh();
  const MeshDistance distance(mesh);
  for (const KnownDistance& c : box_cases()) {
    const ClosestPoint closest = distance.closest(c.point);
    EXPECT_NEAR(closest.distance, c.distance, 1e-12) << c.where;
    EXPECT_NEAR((closest.point - c.point).norm(), c.distance, 1e-12) << c.where;
    EXPECT_GE(closest.triangle, 0);
  }
  // The closest point itself, for a face and an edge case.
  EXPECT_LT((distance.closest({1.0, 0.5, 1.8}).point - Eigen::Vector3d(1.0, 0.5, 1.5)).norm(), 1e-12);
  EXPECT_LT((distance.closest({2.3, 0.5, 1.9}).point - Eigen::Vector3d(2.0, 0.5, 1.5)).norm(), 1e-12);
  EXPECT_NEAR(distance.surface_area(), 2 * (2 * 1 + 2 * 1.5 + 1 * 1.5), 1e-12);
}

TEST(MeshDistance, ParallelDistancesMatchAndRmseIsExact) {
  const MeshDistance distance(box_mesh());
  std::vector<Eigen::Vector3d> points;
  double sum_squares = 0.0;
  for (const KnownDistance& c : box_cases()) {
    points.push_back(c.point);
    sum_squares += c.distance * c.distance;
  }
  const std::vector<double> d = distance.distances(points);
  ASSERT_EQ(d.size(), points.size());
  double rmse_squared = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(d[i], box_cases()[i].distance, 1e-12);
    rmse_squared += d[i] * d[i];
  }
  EXPECT_NEAR(std::sqrt(rmse_squared / d.size()), std::sqrt(sum_squares / d.size()), 1e-12);
}

// A bumpy closed sphere plus loose random triangles (some sliver-thin, one degenerate): many
// triangles of all shapes and orientations, and regions where the nearest one is far away.
TriangleMesh irregular_mesh() {
  TriangleMesh mesh;
  RandomStream random(7, 0, 0, RandomPurpose::kGeneric);
  const int rings = 24, segments = 48;
  mesh.vertices.emplace_back(0.f, 0.f, 1.f);
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double theta = M_PI * r / rings, phi = 2 * M_PI * s / segments;
      const double radius = 1.0 + 0.08 * std::sin(5 * phi) * std::sin(3 * theta) + random.uniform(-0.02, 0.02);
      mesh.vertices.emplace_back(float(radius * std::sin(theta) * std::cos(phi)),
                                 float(radius * std::sin(theta) * std::sin(phi)), float(radius * std::cos(theta)));
    }
  mesh.vertices.emplace_back(0.f, 0.f, -1.f);
  const int south = int(mesh.vertices.size()) - 1;
  auto ring_vertex = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) {
    mesh.triangles.emplace_back(0, ring_vertex(1, s), ring_vertex(1, s + 1));
    mesh.triangles.emplace_back(south, ring_vertex(rings - 1, s + 1), ring_vertex(rings - 1, s));
    for (int r = 1; r < rings - 1; ++r) {
      mesh.triangles.emplace_back(ring_vertex(r, s), ring_vertex(r + 1, s), ring_vertex(r + 1, s + 1));
      mesh.triangles.emplace_back(ring_vertex(r, s), ring_vertex(r + 1, s + 1), ring_vertex(r, s + 1));
    }
  }
  for (int t = 0; t < 300; ++t) {
    const Eigen::Vector3f centre(float(random.uniform(-3, 3)), float(random.uniform(-3, 3)),
                                 float(random.uniform(-3, 3)));
    const int first = int(mesh.vertices.size());
    const double size = t % 10 == 0 ? 0.002 : 0.3;  // some slivers
    for (int k = 0; k < 3; ++k)
      mesh.vertices.push_back(centre + Eigen::Vector3f(float(random.uniform(-size, size)),
                                                       float(random.uniform(-0.3, 0.3)),
                                                       float(random.uniform(-0.3, 0.3))));
    mesh.triangles.emplace_back(first, first + 1, first + 2);
  }
  const int first = int(mesh.vertices.size());  // a degenerate (collinear) triangle
  mesh.vertices.insert(mesh.vertices.end(), {{4.f, 4.f, 4.f}, {4.5f, 4.5f, 4.5f}, {5.f, 5.f, 5.f}});
  mesh.triangles.emplace_back(first, first + 1, first + 2);
  return mesh;
}

TEST(MeshDistance, AgreesWithBruteForceOnRandomPoints) {
  const TriangleMesh mesh = irregular_mesh();
  ASSERT_GT(mesh.num_triangles(), 2000u);
  const MeshDistance distance(mesh, "irregular");
  RandomStream random(11, 0, 0, RandomPurpose::kGeneric);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 1500; ++i)
    points.emplace_back(random.uniform(-4, 4), random.uniform(-4, 4), random.uniform(-4, 4));
  for (int i = 0; i < 400; ++i) {  // close to the sphere, inside and outside
    const Eigen::Vector3d direction = Eigen::Vector3d(random.normal(), random.normal(), random.normal()).normalized();
    points.push_back(direction * random.uniform(0.9, 1.1));
  }
  for (int i = 0; i < 50; ++i)  // far away: the slack logic must still find the exact minimum
    points.emplace_back(random.uniform(-300, 300), random.uniform(-300, 300), random.uniform(-300, 300));
  points.emplace_back(4.25, 4.25, 4.26);  // next to the degenerate triangle

  const std::vector<double> fast = distance.distances(points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ClosestPoint reference = closest_point_brute_force(mesh, points[i]);
    ASSERT_NEAR(fast[i], reference.distance, 1e-12) << "point " << i << ": " << points[i].transpose();
    const ClosestPoint closest = distance.closest(points[i]);
    EXPECT_NEAR((closest.point - points[i]).norm(), reference.distance, 1e-12);
  }
}

TEST(MeshDistance, ResultDoesNotDependOnThreadCount) {
  const TriangleMesh mesh = irregular_mesh();
  const MeshDistance distance(mesh);
  RandomStream random(3, 0, 0, RandomPurpose::kGeneric);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 5000; ++i)
    points.emplace_back(random.uniform(-2, 2), random.uniform(-2, 2), random.uniform(-2, 2));
  std::vector<double> one_thread;
  tbb::task_arena(1).execute([&] { one_thread = distance.distances(points); });
  EXPECT_EQ(one_thread, distance.distances(points));
}

TEST(MeshDistance, SegmentVisibility) {
  const MeshDistance distance(box_mesh());
  // Inside the box, to a point on a wall: clear. From outside, through a wall: blocked.
  EXPECT_FALSE(distance.segment_blocked({1.0, 0.5, 0.75}, {2.0, 0.5, 0.75}, 1e-3));
  EXPECT_TRUE(distance.segment_blocked({3.0, 0.5, 0.75}, {1.0, 0.5, 0.75}, 1e-3));
  EXPECT_FALSE(distance.segment_blocked({3.0, 0.5, 0.75}, {2.5, 0.5, 0.75}, 1e-3));
}

TEST(MeshDistance, BadInput) {
  TriangleMesh empty = box_mesh();
  empty.triangles.clear();
  EXPECT_THAT(
      [&] {
        try {
          MeshDistance d(empty, "gt.ply");
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("gt.ply"));
  TriangleMesh bad_index = box_mesh();
  bad_index.triangles[3][1] = 99;
  EXPECT_THROW(MeshDistance(bad_index, "gt.ply"), Error);
  TriangleMesh nan_vertex = box_mesh();
  nan_vertex.vertices[2].x() = std::nanf("");
  EXPECT_THROW(MeshDistance(nan_vertex, "gt.ply"), Error);

  const MeshDistance distance(box_mesh());
  std::vector<Eigen::Vector3d> points = {{0, 0, 0}, {1, 2, 3}, {1, std::nan(""), 3}};
  try {
    distance.distances(points, "cloud.ply");
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("cloud.ply"));
    EXPECT_THAT(e.what(), HasSubstr("point 2"));
  }
}

}  // namespace
}  // namespace panoscan::eval
