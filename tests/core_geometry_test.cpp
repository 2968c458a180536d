#include <algorithm>
#include <vector>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

#include "panoscan/core/allocator.h"
#include "panoscan/core/process.h"
#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/core/rigid_ransac.h"

using namespace panoscan;

TEST(Geometry, So3ExpLogRoundTrip) {
  for (const Eigen::Vector3d& w : {Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector3d(1e-9, 0, 0),
                                   Eigen::Vector3d(0, 3.0, 0), Eigen::Vector3d(-2.0, 1.0, 0.5)}) {
    const Eigen::Matrix3d r = so3_exp(w);
    EXPECT_NEAR((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR((so3_log(r) - w).norm(), 0.0, 1e-9) << w.transpose();
    EXPECT_NEAR(rotation_angle(r), w.norm(), 1e-9);
  }
}

TEST(Geometry, FitRigidTransformRecoversAKnownPoseAndRejectsDegenerateSets) {
  const Rigid3d truth = make_rigid(so3_exp(Eigen::Vector3d(0.3, -1.2, 2.0)), Eigen::Vector3d(1, -2, 0.5));
  std::vector<Eigen::Vector3d> from, to;
  for (int i = 0; i < 10; ++i) {
    from.push_back(Eigen::Vector3d::Random());
    to.push_back(truth * from.back());
  }
  Rigid3d fitted = Rigid3d::Identity();
  ASSERT_TRUE(fit_rigid_transform(from, to, fitted));
  EXPECT_LT((fitted.matrix() - truth.matrix()).norm(), 1e-12);
  // Collinear points leave a rotation free.
  const std::vector<Eigen::Vector3d> line = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                             Eigen::Vector3d(2, 0, 0)};
  EXPECT_FALSE(fit_rigid_transform(line, line, fitted));
  EXPECT_FALSE(fit_rigid_transform({from[0], from[1]}, {to[0], to[1]}, fitted));
}

TEST(Geometry, FitRigidTransformOfPosesRecoversAKnownTransformOfAnInPlaceRotation) {
  // Cameras turning about one vertical axis through a fixed point: their positions are one point,
  // so only the orientations fix the rotation.
  const Rigid3d truth = make_rigid(so3_exp(Eigen::Vector3d(0.2, -0.4, 1.5)), Eigen::Vector3d(0.5, 1, -2));
  std::vector<Rigid3d> from, to;
  for (int i = 0; i < 12; ++i) {
    from.push_back(make_rigid(so3_exp(Eigen::Vector3d(0, 0, 0.5 * i)), Eigen::Vector3d(0.1, 0.2, 1.1)));
    to.push_back(truth * from.back());
  }
  EXPECT_LT((fit_rigid_transform_of_poses(from, to).matrix() - truth.matrix()).norm(), 1e-12);
  EXPECT_TRUE(fit_rigid_transform_of_poses({}, {}).isApprox(Rigid3d::Identity()));
}

TEST(Geometry, ClosestRotationIsAProperRotationAndFlagsRankDeficiency) {
  bool rank_deficient = true;
  const Eigen::Matrix3d reflection = Eigen::Vector3d(1, 1, -1).asDiagonal();
  const Eigen::Matrix3d r = closest_rotation(reflection, &rank_deficient);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  EXPECT_FALSE(rank_deficient);
  closest_rotation(Eigen::Vector3d(1, 0, 0).asDiagonal(), &rank_deficient);
  EXPECT_TRUE(rank_deficient);
}

TEST(Geometry, WrapAngles) {
  EXPECT_NEAR(wrap_two_pi(-0.5), 2 * M_PI - 0.5, 1e-12);
  EXPECT_NEAR(wrap_two_pi(7.0), 7.0 - 2 * M_PI, 1e-12);
  EXPECT_NEAR(wrap_pi(3.5), 3.5 - 2 * M_PI, 1e-12);
  EXPECT_NEAR(wrap_pi(-0.2), -0.2, 1e-12);
}

TEST(Geometry, PointTriangleDistanceRegions) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  Eigen::Vector3d closest;
  // Above the face.
  EXPECT_NEAR(point_triangle_distance({0.2, 0.2, 0.7}, a, b, c, &closest), 0.7, 1e-15);
  EXPECT_NEAR((closest - Eigen::Vector3d(0.2, 0.2, 0)).norm(), 0.0, 1e-15);
  // Vertex regions.
  EXPECT_NEAR(point_triangle_distance({-1, -1, 0}, a, b, c), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(point_triangle_distance({2, 0, 1}, a, b, c), std::sqrt(2.0), 1e-15);
  // Edge region (hypotenuse): point (1,1,0) is sqrt(2)/2 from the edge b-c.
  EXPECT_NEAR(point_triangle_distance({1, 1, 0}, a, b, c), std::sqrt(0.5), 1e-15);
  // Edge a-b from below.
  EXPECT_NEAR(point_triangle_distance({0.5, -0.3, 0.4}, a, b, c), 0.5, 1e-15);
  // Degenerate triangle (collinear points).
  EXPECT_NEAR(point_triangle_distance({0.5, 1, 0}, a, b, Eigen::Vector3d(2, 0, 0)), 1.0, 1e-15);
}

TEST(Geometry, PointTriangleDistanceMatchesDenseSampling) {
  const Eigen::Vector3d a(0.3, -0.2, 0.1), b(1.2, 0.4, -0.3), c(-0.1, 0.9, 0.5);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d::Random() * 1.5;
    double best = 1e9;
    for (int s = 0; s <= 400; ++s)
      for (int t = 0; s + t <= 400; ++t) {
        const Eigen::Vector3d q = a + (b - a) * (s / 400.0) + (c - a) * (t / 400.0);
        best = std::min(best, (p - q).norm());
      }
    EXPECT_LE(point_triangle_distance(p, a, b, c), best + 1e-12);
    EXPECT_NEAR(point_triangle_distance(p, a, b, c), best, 5e-3);
  }
}

TEST(Camera, PinholeRoundTripAndFieldOfView) {
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(640, 480);
  EXPECT_NEAR(rad2deg(k.fov_x()), 58.6, 0.2);
  EXPECT_NEAR(rad2deg(k.fov_y()), 45.6, 0.2);
  const Eigen::Vector3d p = k.backproject(100.25, 400.5, 2.5);
  const Eigen::Vector2d uv = k.project(p);
  EXPECT_NEAR(uv.x(), 100.25, 1e-12);
  EXPECT_NEAR(uv.y(), 400.5, 1e-12);
  EXPECT_NEAR(p.z(), 2.5, 1e-15);
  // The principal point sees the optical axis.
  EXPECT_NEAR(k.backproject(k.cx, k.cy, 1.0).head<2>().norm(), 0.0, 1e-15);
  const PinholeIntrinsics small = PinholeIntrinsics::primesense(160, 120);
  EXPECT_NEAR(small.fov_x(), k.fov_x(), 1e-12);
}

TEST(Camera, EquirectangularRoundTrip) {
  const Equirectangular pano{256};
  EXPECT_EQ(pano.width(), 512);
  for (double u : {0.0, 10.3, 255.5, 511.0})
    for (double v : {0.0, 64.2, 128.0, 255.0}) {
      const Eigen::Vector2d back = pano.pixel(pano.direction(u, v));
      EXPECT_NEAR(back.x(), u, 1e-9);
      EXPECT_NEAR(back.y(), v, 1e-9);
    }
  // Row 0 looks up, the middle row looks at the horizon.
  EXPECT_GT(pano.direction(10, 0).z(), 0.99);
  EXPECT_NEAR(pano.direction(10, 127.5).z(), 0.0, 1e-12);
}

// pixel() against the angles in long double (libm's atan2l, 64-bit mantissa): within 4 units in
// the last place of the pixel coordinate at the largest panorama (W = 32768), over random
// directions of every scale and octant and the special ones (axes, poles, the seam, the tan(pi/8)
// switch of the reduction, signed zeros).
TEST(Camera, EquirectangularPixelIsAccurateToAFewUlps) {
  const Equirectangular pano{16384};
  RandomStream random(11, 0, 0, RandomPurpose::kGeneric);
  std::vector<Eigen::Vector3d> directions;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d d(random.uniform(-1, 1), random.uniform(-1, 1), random.uniform(-1, 1));
    if (i % 4 == 1) d.y() = d.x() * std::tan(M_PI / 8) * (1 + 1e-9 * random.uniform(-1, 1));  // the switch
    if (i % 4 == 2) d.head<2>() *= 1e-6;                                                      // near a pole
    directions.push_back(d * std::pow(10.0, random.uniform(-3, 3)));
  }
  for (const double x : {-1.0, -0.0, 0.0, 1.0})
    for (const double y : {-1.0, -0.0, 0.0, 1.0})
      for (const double z : {-1.0, 0.0, 1.0})
        if (x != 0 || y != 0 || z != 0) directions.emplace_back(x, y, z);
  directions.emplace_back(1.0, -1e-300, 0.2);  // just below the seam: u = W - 1/2
  const long double pi = 3.141592653589793238462643383279502884L;
  for (const Eigen::Vector3d& d : directions) {
    const long double x = d.x(), y = d.y(), z = d.z();
    long double phi = std::atan2(y, x);
    if (phi < 0) phi += 2 * pi;
    const long double theta = std::atan2(std::sqrt(x * x + y * y), z);
    const long double u = phi / (2 * pi) * pano.width() - 0.5L, v = theta / pi * pano.height - 0.5L;
    const Eigen::Vector2d got = pano.pixel(d);
    // At a pole the azimuth is arbitrary (libm: atan2(0, -0) = pi; pixel(): 0).
    if (d.x() != 0 || d.y() != 0) {
      EXPECT_NEAR(got.x(), double(u), 4 * DBL_EPSILON * double(u + 1)) << d.transpose();
    }
    EXPECT_NEAR(got.y(), double(v), 4 * DBL_EPSILON * double(v + 1)) << d.transpose();
  }
}

// pixels() is pixel() bit for bit, whichever SIMD path takes which element (n = 4k + 3 gives the
// AVX path, one SSE2 pair and one scalar element where the CPU has AVX).
TEST(Camera, EquirectangularPixelsBatchIsBitIdenticalToPixel) {
  const Equirectangular pano{1024};
  RandomStream random(12, 0, 0, RandomPurpose::kGeneric);
  const std::size_t n = 4003;
  std::vector<double> x(n), y(n), z(n), u(n), v(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = random.uniform(-5, 5), y[i] = random.uniform(-5, 5), z[i] = random.uniform(-5, 5);
    if (i % 7 == 0) x[i] = 0.0;
    if (i % 11 == 0) y[i] = -0.0;
  }
  pano.pixels(n, x.data(), y.data(), z.data(), u.data(), v.data());
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d expected = pano.pixel(Eigen::Vector3d(x[i], y[i], z[i]));
    ASSERT_EQ(u[i], expected.x()) << i;
    ASSERT_EQ(v[i], expected.y()) << i;
  }
}

// Pairs where a share `inliers` follows `truth` within 1 mm and the rest are scattered in the room.
void ransac_pairs(double inliers, const Rigid3d& truth, std::vector<Eigen::Vector3d>* a,
                  std::vector<Eigen::Vector3d>* b) {
  RandomStream random(3, 0, 0, RandomPurpose::kGeneric);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(random.uniform(-2, 2), random.uniform(-1, 1), random.uniform(1, 5));
    b->push_back(p);
    if (i < int(inliers * 200))
      a->push_back(truth * p + 1e-3 * Eigen::Vector3d(random.normal(), random.normal(), random.normal()));
    else
      a->push_back(Eigen::Vector3d(random.uniform(-2, 2), random.uniform(-1, 1), random.uniform(1, 5)));
  }
}

TEST(RigidRansac, StopsOnceAnAllInlierSampleIsLikelyAndStillFindsThePose) {
  EXPECT_EQ(ransac_iterations_needed(0.999, 0.5), 52.0);  // log(1e-3) / log(1 - 1/8) = 51.7
  EXPECT_EQ(ransac_iterations_needed(0.9999, 1.0), 1.0);
  EXPECT_TRUE(std::isinf(ransac_iterations_needed(1.0, 0.9)));   // confidence 1: every draw
  EXPECT_TRUE(std::isinf(ransac_iterations_needed(0.9999, 0.0)));
  const Rigid3d truth = make_rigid(so3_exp(Eigen::Vector3d(0.02, -0.3, 0.05)), Eigen::Vector3d(0.1, 0.0, -0.05));
  for (const double share : {0.9, 0.5, 0.25}) {
    std::vector<Eigen::Vector3d> a, b;
    ransac_pairs(share, truth, &a, &b);
    const std::vector<double> thresholds(a.size(), 0.005);
    RigidRansacResult every, adaptive;
    ASSERT_TRUE(rigid_ransac(a, b, thresholds, {2000, 1.0, 0}, 12, 1, 0, &every)) << share;
    ASSERT_TRUE(rigid_ransac(a, b, thresholds, {2000, 0.9999, 20}, 12, 1, 0, &adaptive)) << share;
    EXPECT_EQ(every.iterations, 2000);
    // The rule's own bound at the true share (the best consensus found is at most the true share,
    // and reaching it ends the search), and never below the minimum.
    EXPECT_GE(adaptive.iterations, 20);
    EXPECT_LE(adaptive.iterations, std::max(20.0, ransac_iterations_needed(0.9999, share * 0.95)) + 1) << share;
    EXPECT_LT(adaptive.iterations, 2000) << share;
    for (const RigidRansacResult* r : {&every, &adaptive}) {
      EXPECT_NEAR(double(r->inliers.size()), share * 200, 2.0) << share;
      EXPECT_LT((r->a_from_b.matrix() - truth.matrix()).norm(), 2e-3) << share;
    }
  }
}

TEST(Allocator, GlibcAcceptsTheSettings) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's allocator stands in for glibc's and refuses its settings";
#elif defined(__GLIBC__)
  // A check of the build as much as of glibc: without <features.h> seen first, __GLIBC__ was
  // undefined inside allocator.cpp and the settings silently compiled to nothing.
  EXPECT_TRUE(keep_freed_memory_for_reuse());
#else
  GTEST_SKIP() << "not glibc";
#endif
}

TEST(Process, HugePageHeapTunablesAddTheSettingOnceAndKeepTheUsers) {
  EXPECT_EQ(huge_page_heap_tunables(nullptr), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(huge_page_heap_tunables(""), "glibc.malloc.hugetlb=1");
  EXPECT_EQ(huge_page_heap_tunables("glibc.malloc.arena_max=2"), "glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1");
  // Already there (the re-executed process) or the user's own choice: nothing to change.
  EXPECT_EQ(huge_page_heap_tunables("glibc.malloc.hugetlb=1"), "");
  EXPECT_EQ(huge_page_heap_tunables("glibc.malloc.arena_max=2:glibc.malloc.hugetlb=0"), "");
  EXPECT_EQ(huge_page_heap_tunables("glibc.malloc.hugetlb=2:glibc.malloc.arena_max=2"), "");
  // Names are matched whole.
  EXPECT_EQ(huge_page_heap_tunables("glibc.malloc.hugetlbx=1"), "glibc.malloc.hugetlbx=1:glibc.malloc.hugetlb=1");
  EXPECT_EQ(huge_page_heap_tunables("x.glibc.malloc.hugetlb=0"), "x.glibc.malloc.hugetlb=0:glibc.malloc.hugetlb=1");
}

TEST(Allocator, DefaultInitAllocatorLeavesSizedElementsToTheirWriter) {
  // construct() without a value default-initialises: a double's bytes stay as they were (a
  // value-initialising allocator writes zeros here).
  alignas(double) unsigned char storage[sizeof(double)];
  std::memset(storage, 0xAB, sizeof storage);
  DefaultInitAllocator<double> allocator;
  allocator.construct(reinterpret_cast<double*>(storage));
  for (const unsigned char byte : storage) EXPECT_EQ(byte, 0xAB);
  // Given a value, and for types with a constructor, elements are constructed as std::vector does.
  UninitialisedVector<double> filled;
  filled.resize(5, 2.5);
  filled.push_back(-1.0);
  EXPECT_EQ(filled, (UninitialisedVector<double>{2.5, 2.5, 2.5, 2.5, 2.5, -1.0}));
  filled.assign(3, 0.0);
  EXPECT_EQ(filled, (UninitialisedVector<double>{0.0, 0.0, 0.0}));
  struct WithInitialiser {
    int value = 42;
  };
  const UninitialisedVector<WithInitialiser> constructed(4);
  for (const WithInitialiser& element : constructed) EXPECT_EQ(element.value, 42);
}

TEST(Allocator, LargeBlocksAreAdvisedHugePages) {
  std::vector<char> small(std::size_t(1) << 20);
  EXPECT_FALSE(advise_huge_pages(small.data(), small.size()));  // below 8 MB: left alone
  EXPECT_FALSE(advise_huge_pages(nullptr, std::size_t(64) << 20));
#if defined(__linux__)
  if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage")) GTEST_SKIP() << "kernel without THP";
  UninitialisedVector<double> large;
  large.resize(std::size_t(4) << 20);  // 32 MB
  EXPECT_TRUE(advise_huge_pages(large.data(), large.size() * sizeof(double)));
#endif
}
