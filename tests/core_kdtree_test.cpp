// PointKdTree against brute force: k nearest and the nearest within a radius (the bounded search
// that registration's correspondence step relies on).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "panoscan/core/kdtree.h"

namespace panoscan {
namespace {

std::vector<Eigen::Vector3d> random_points(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::Vector3d> points(n);
  for (auto& p : points) p = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
  return points;
}

TEST(PointKdTree, NearestWithinMatchesBruteForce) {
  const std::vector<Eigen::Vector3d> points = random_points(5000, 1);
  const PointKdTree tree(points);
  const std::vector<Eigen::Vector3d> queries = random_points(500, 2);
  int found = 0, none = 0;
  for (const Eigen::Vector3d& q : queries)
    for (double radius : {0.02, 0.05, 0.2}) {
      long best = -1;
      double best_d2 = radius * radius;
      for (std::size_t j = 0; j < points.size(); ++j) {
        const double d2 = (points[j] - q).squaredNorm();
        if (d2 < best_d2) best_d2 = d2, best = long(j);
      }
      double d2 = -1;
      const long j = tree.nearest_within(q, radius, &d2);
      ASSERT_EQ(j, best) << "radius " << radius;
      if (j >= 0) {
        EXPECT_DOUBLE_EQ(d2, best_d2);
        ++found;
      } else {
        ++none;
      }
    }
  // Both outcomes occur: the radii straddle the typical spacing.
  EXPECT_GT(found, 100);
  EXPECT_GT(none, 100);
}

TEST(PointKdTree, KnnIsSortedAndMatchesBruteForce) {
  const std::vector<Eigen::Vector3d> points = random_points(3000, 3);
  const PointKdTree tree(points);
  for (const Eigen::Vector3d& q : random_points(50, 4)) {
    std::vector<double> all(points.size());
    for (std::size_t j = 0; j < points.size(); ++j) all[j] = (points[j] - q).squaredNorm();
    std::sort(all.begin(), all.end());
    std::uint32_t indices[20];
    double squared[20];
    ASSERT_EQ(tree.knn(q, 20, indices, squared), 20u);
    for (int k = 0; k < 20; ++k) EXPECT_DOUBLE_EQ(squared[k], all[std::size_t(k)]);
  }
}

// knn_within: the k nearest strictly closer than the radius, closest first, and fewer (down to none)
// when fewer are that close. Registration's correspondence step relies on "every point not returned
// is at least as far as the k-th returned one, or as the radius".
TEST(PointKdTree, KnnWithinMatchesBruteForce) {
  const std::vector<Eigen::Vector3d> points = random_points(3000, 7);
  const PointKdTree tree(points);
  const std::vector<Eigen::Vector3d> queries = random_points(300, 8);
  std::size_t fewer = 0, none = 0;
  for (std::size_t t = 0; t < queries.size(); ++t) {
    const Eigen::Vector3d& q = queries[t];
    const double radius = 0.02 + 0.1 * double(t % 7) / 6.0;
    std::vector<double> sorted;
    for (const Eigen::Vector3d& p : points)
      if ((p - q).squaredNorm() < radius * radius) sorted.push_back((p - q).squaredNorm());
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t k : {1, 2, 5}) {
      std::uint32_t indices[5];
      double squared[5];
      const std::size_t found = tree.knn_within(q, k, radius, indices, squared);
      ASSERT_EQ(found, std::min(k, sorted.size())) << t << " k " << k;
      for (std::size_t j = 0; j < found; ++j) {
        EXPECT_EQ(squared[j], sorted[j]) << t << " k " << k;
        EXPECT_EQ(squared[j], (points[indices[j]] - q).squaredNorm());
      }
      fewer += found < k;
      none += found == 0;
    }
  }
  EXPECT_GT(fewer, 0u);  // the radius did cut some searches short
  EXPECT_GT(none, 0u);
}

TEST(PointKdTree, EmptyTreeFindsNothing) {
  const PointKdTree tree({});
  std::uint32_t index;
  double d2;
  EXPECT_EQ(tree.knn(Eigen::Vector3d::Zero(), 1, &index, &d2), 0u);
  EXPECT_EQ(tree.nearest_within(Eigen::Vector3d::Zero(), 1.0), -1);
  EXPECT_EQ(tree.knn_within(Eigen::Vector3d::Zero(), 1, 1.0, &index, &d2), 0u);
}

}  // namespace
}  // namespace panoscan
