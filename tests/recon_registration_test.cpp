// The ICP family (Table 4 rows) on panoramic point sets rendered from two centres of a room.
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/core/random.h"
#include "panoscan/recon/feature_alignment.h"
#include "panoscan/recon/outside_references.h"
#include "panoscan/recon/point_covariance.h"
#include "panoscan/recon/registration.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/renderer.h"
#include "test_util.h"

using namespace panoscan;

namespace {

// Appends an axis-aligned box (outward faces) to the scene.
void add_box(Scene& scene, Eigen::Vector3f lo, Eigen::Vector3f hi) {
  auto& m = scene.mesh;
  const int base = int(m.vertices.size());
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads)
    for (const auto& tri : {Eigen::Vector3i(q[0], q[1], q[2]), Eigen::Vector3i(q[0], q[2], q[3])}) {
      m.triangles.push_back(tri + Eigen::Vector3i::Constant(base));
      m.triangle_material.push_back(0);
      for (int k = 0; k < 3; ++k) m.corner_uvs.emplace_back(0.f, 0.f);
    }
}

Scene furnished_room() {
  Scene scene = testutil::make_box_room(-2.0, 3.0, -2.5, 2.0, 2.7, Eigen::Vector3d(0, 0, 0));
  add_box(scene, {1.0f, 0.8f, 0.0f}, {2.2f, 1.6f, 0.75f});     // table
  add_box(scene, {-1.8f, -2.3f, 0.0f}, {-1.2f, -0.9f, 1.9f});  // shelf
  add_box(scene, {0.6f, -1.9f, 0.0f}, {1.1f, -1.4f, 1.1f});    // cabinet
  return scene;
}

struct Panorama {
  Rigid3d world_from_pano;
  RegistrationCloud cloud;  // in the panorama's frame
};

// Points of an equirectangular depth panorama with noise along the ray: std `sigma_near` on the
// left half of the image, `sigma_far` on the right; measurement covariances per Eq. 9 either with
// the true per-pixel std ("measured") or with a depth-only model.
Panorama make_panorama(const Renderer& renderer, const Rigid3d& world_from_pano, double sigma_left, double sigma_right,
                       std::uint64_t seed, bool model_covariance = false) {
  const Equirectangular pano{96};
  // These points lie exactly on their pixel-centre rays (no rasterisation), so their angular
  // uncertainty is ~0; fused panoramas use half a pixel (Eq. 9). Modelling half a pixel here
  // (3 cm at 2 m for H = 96) would down-weight oblique surfaces for an error they do not have.
  const double angle_sigma = 1e-4;
  const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
  Panorama result{world_from_pano, {}};
  RandomStream rng(seed, 0, 0, RandomPurpose::kGeneric);
  for (int v = 0; v < pano.height; ++v)
    for (int u = 0; u < pano.width(); ++u) {
      const double depth = view.depth.at(u, v);
      if (depth <= 0.3) continue;
      const double sigma = u < pano.width() / 2 ? sigma_left : sigma_right;
      const double noisy = depth + rng.normal() * sigma;
      result.cloud.points.push_back(pano.direction(u, v) * noisy);
      const double phi = 2 * M_PI * (u + 0.5) / pano.width(), theta = M_PI * (v + 0.5) / pano.height;
      const double sigma_used = model_covariance ? 9.49e-4 * depth * depth : sigma;
      result.cloud.measurement_covariances.push_back(
          equirectangular_point_covariance(phi, theta, noisy, angle_sigma, sigma_used));
      result.cloud.confidence.push_back(1.f);
    }
  prepare_surface(result.cloud, Eigen::Vector3d::Zero(), SurfaceOptions{});
  return result;
}

double rotation_error_deg(const Rigid3d& a, const Rigid3d& b) {
  return rad2deg(rotation_angle(a.linear().transpose() * b.linear()));
}

const IcpMethod kAllMethods[] = {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane, IcpMethod::kPointToPlaneCurvature,
                                 IcpMethod::kGicp,         IcpMethod::kAnisotropic,  IcpMethod::kGicpNoiseModel,
                                 IcpMethod::kGicpMeasured};

}  // namespace

TEST(PointCovariance, MatchesTheNumericJacobianOfTheBackProjection) {
  const double phi = 1.1, theta = 0.7, z = 2.3, sa = 0.01, sz = 0.02;
  auto point = [](double f, double t, double r) {
    return Eigen::Vector3d(r * std::sin(t) * std::cos(f), r * std::sin(t) * std::sin(f), r * std::cos(t));
  };
  const double h = 1e-6;
  Eigen::Matrix3d jacobian;
  jacobian.col(0) = (point(phi + h, theta, z) - point(phi - h, theta, z)) / (2 * h);
  jacobian.col(1) = (point(phi, theta + h, z) - point(phi, theta - h, z)) / (2 * h);
  jacobian.col(2) = (point(phi, theta, z + h) - point(phi, theta, z - h)) / (2 * h);
  const Eigen::Matrix3d expected =
      jacobian * Eigen::Vector3d(sa * sa, sa * sa, sz * sz).asDiagonal() * jacobian.transpose();
  EXPECT_LT((equirectangular_point_covariance(phi, theta, z, sa, sz) - expected).norm(), 1e-9);
  // Along the ray the variance is sigma_z^2.
  const Eigen::Vector3d ray = point(phi, theta, 1.0);
  EXPECT_NEAR(ray.dot(equirectangular_point_covariance(phi, theta, z, sa, sz) * ray), sz * sz, 1e-12);
}

class EveryMethod : public ::testing::TestWithParam<IcpMethod> {};

// Two panoramas of the furnished room 1.06 m and 46 deg apart, noise sigma, and a guess 3.5 deg /
// 8.4 cm off the truth.
struct KnownPair {
  Panorama target, source;
  Rigid3d truth, initial;
};
KnownPair known_pair(double sigma) {
  const Scene scene = furnished_room();
  const Renderer renderer(scene);
  const Rigid3d world_from_target = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.3, 1.2));
  const Rigid3d world_from_source =
      make_rigid(so3_exp(Eigen::Vector3d(0.01, -0.015, 0.8)), Eigen::Vector3d(1.0, 0.4, 1.15));
  KnownPair pair{make_panorama(renderer, world_from_target, sigma, sigma, 1),
                 make_panorama(renderer, world_from_source, sigma, sigma, 2), Rigid3d::Identity(),
                 Rigid3d::Identity()};
  pair.truth = world_from_target.inverse() * world_from_source;
  pair.initial =
      make_rigid(so3_exp(Eigen::Vector3d(0.02, -0.03, 0.05)), Eigen::Vector3d(0.06, -0.05, 0.03)) * pair.truth;
  return pair;
}

TEST_P(EveryMethod, RecoversAKnownTransformFromAPerturbedGuess) {
  const KnownPair pair = known_pair(0.001);
  const Panorama& target = pair.target;
  const Panorama& source = pair.source;
  const Rigid3d& truth = pair.truth;
  const Rigid3d& initial = pair.initial;
  IcpOptions options;
  options.method = GetParam();
  const IcpResult result = register_icp(source.cloud, target.cloud, initial, options);
  // Point-to-point matches points of two different sampling grids (6 cm apart at 2 m here) and
  // keeps their offset as a bias: the weakest row of Table 4, with its own tolerance.
  const bool point_to_point = GetParam() == IcpMethod::kPointToPoint;
  EXPECT_LT(rotation_error_deg(result.target_from_source, truth), point_to_point ? 0.4 : 0.1) << to_string(GetParam());
  EXPECT_LT((result.target_from_source.translation() - truth.translation()).norm(), point_to_point ? 0.02 : 0.005)
      << to_string(GetParam());
  EXPECT_GT(result.inlier_fraction, 0.5);
  EXPECT_LT(result.cost_history.back(), result.cost_history.front());
}

INSTANTIATE_TEST_SUITE_P(Table4, EveryMethod, ::testing::ValuesIn(kAllMethods),
                         [](const ::testing::TestParamInfo<IcpMethod>& info) {
                           std::string name = to_string(info.param);
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

TEST(Registration, MeasuredVarianceBeatsPlainGicpOnHeteroscedasticNoise) {
  // Half of each panorama is 40x noisier. Using each pixel's own variance (Eq. 9, "Ours")
  // must give a clearly smaller error than plain GICP, on average over several noise draws
  // (measured: 0.44 vs 0.96 mm; with equal noise everywhere the two agree, 0.15 vs 0.15 mm).
  const Scene scene = furnished_room();
  const Renderer renderer(scene);
  const Rigid3d world_from_target = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.3, 1.2));
  const Rigid3d world_from_source = make_rigid(so3_exp(Eigen::Vector3d(0.0, 0.0, 0.6)), Eigen::Vector3d(0.9, 0.3, 1.2));
  const Rigid3d truth = world_from_target.inverse() * world_from_source;
  double error_gicp = 0, error_ours = 0;
  const double sigma_left = 0.002, sigma_right = 0.08;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    const Panorama target = make_panorama(renderer, world_from_target, sigma_left, sigma_right, 10 + seed);
    const Panorama source = make_panorama(renderer, world_from_source, sigma_left, sigma_right, 20 + seed);
    IcpOptions options;
    options.method = IcpMethod::kGicp;
    error_gicp += (register_icp(source.cloud, target.cloud, truth, options).target_from_source.translation() -
                   truth.translation())
                      .norm();
    options.method = IcpMethod::kGicpMeasured;
    error_ours += (register_icp(source.cloud, target.cloud, truth, options).target_from_source.translation() -
                   truth.translation())
                      .norm();
  }
  std::printf("mean translation error: plain GICP %.2f mm, measured variance %.2f mm\n", error_gicp / 4 * 1e3,
              error_ours / 4 * 1e3);
  EXPECT_LT(error_ours, 0.75 * error_gicp);
}

// correspond() skips the search for a point whose remembered match is provably still its nearest
// (it moved less than the gap to the second nearest). Stopped after 1-4 steps from the 3.5 deg / 8.4 cm
// guess, while the pose still moves by millimetres, the last correspondences must be exactly the
// nearest points within lambda_a at the returned pose: the same count and the same Euclidean RMSE as a
// fresh search of every point.
TEST(Registration, SkippedSearchesStillFindTheNearestPoints) {
  const KnownPair pair = known_pair(0.001);
  const RegistrationCloud& source = pair.source.cloud;
  const RegistrationCloud& target = pair.target.cloud;
  const PointKdTree tree(target.points);
  for (const IcpMethod method : {IcpMethod::kGicpMeasured, IcpMethod::kPointToPlane})
    for (int steps = 1; steps <= 4; ++steps) {
      IcpOptions options;
      options.method = method;
      options.max_iterations = steps;
      options.coarse_levels = 0;
      options.min_fitness = 0;
      const IcpResult result = register_icp(source, target, pair.initial, options);
      std::size_t count = 0;
      double squared_error = 0;
      for (const Eigen::Vector3d& p : source.points) {
        const Eigen::Vector3d q = result.target_from_source * p;
        double squared = 0;
        if (tree.nearest_within(q, options.max_correspondence_m, &squared) < 0) continue;
        ++count;
        squared_error += squared;
      }
      ASSERT_GT(count, 0u);
      EXPECT_EQ(result.correspondences, count) << to_string(method) << ", " << steps << " steps";
      EXPECT_NEAR(result.rmse_m, std::sqrt(squared_error / double(count)), 1e-12)
          << to_string(method) << ", " << steps << " steps";
    }
}

TEST(Registration, SameResultWithOneAndTwoThreads) {
  const Scene scene = furnished_room();
  const Renderer renderer(scene);
  const Panorama target = make_panorama(
      renderer, make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.3, 1.2)), 0.003, 0.003, 1);
  const Panorama source =
      make_panorama(renderer, make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.7, 0.1, 1.2)), 0.003, 0.003, 2);
  IcpOptions options;
  options.threads = 1;
  const IcpResult one = register_icp(source.cloud, target.cloud, Rigid3d::Identity(), options);
  options.threads = 2;
  const IcpResult two = register_icp(source.cloud, target.cloud, Rigid3d::Identity(), options);
  EXPECT_EQ(one.target_from_source.matrix(), two.target_from_source.matrix());
  EXPECT_EQ(one.iterations, two.iterations);
}

TEST(Registration, CoarseToFineReachesTheMinimumOfTheFullCloud) {
  // The coarse levels only move the pose near the minimum; the finest level, on every point,
  // decides where it ends: the same pose as Gauss-Newton on all points from the start, to far
  // below the noise floor, in fewer full-cloud iterations.
  const KnownPair pair = known_pair(0.003);
  const Panorama& target = pair.target;
  const Panorama& source = pair.source;
  const Rigid3d& initial = pair.initial;
  for (IcpMethod method : {IcpMethod::kGicp, IcpMethod::kGicpMeasured, IcpMethod::kPointToPlane}) {
    IcpOptions options;
    options.method = method;
    options.coarse_min_points = 500;  // the test panoramas are small: make both coarse levels run
    options.coarse_levels = 0;
    const IcpResult flat = register_icp(source.cloud, target.cloud, initial, options);
    options.coarse_levels = 2;
    const IcpResult pyramid = register_icp(source.cloud, target.cloud, initial, options);
    ASSERT_TRUE(flat.converged && pyramid.converged) << to_string(method);
    const Rigid3d difference = flat.target_from_source.inverse() * pyramid.target_from_source;
    EXPECT_LT(difference.translation().norm(), 2e-5) << to_string(method);
    EXPECT_LT(so3_log(difference.linear()).norm(), 2e-5) << to_string(method);
    // Fewer iterations on the full cloud (the cost history holds the finest level's only).
    EXPECT_LT(pyramid.cost_history.size(), flat.cost_history.size()) << to_string(method);
    EXPECT_GT(pyramid.iterations, int(pyramid.cost_history.size())) << to_string(method);
  }
}

TEST(Registration, BadInputIsAClearError) {
  RegistrationCloud empty;
  RegistrationCloud points;
  points.points = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(0, 1, 1)};
  IcpOptions options;
  options.method = IcpMethod::kPointToPoint;
  EXPECT_THROW(register_icp(empty, points, Rigid3d::Identity(), options), Error);
  options.method = IcpMethod::kGicpMeasured;  // needs surfaces and covariances
  try {
    register_icp(points, points, Rigid3d::Identity(), options);
    FAIL() << "a cloud without covariances was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("prepare_surface"), std::string::npos) << e.what();
  }
  // No overlap within the correspondence distance: a loud failure, not a silent identity.
  options.method = IcpMethod::kPointToPoint;
  RegistrationCloud far = points;
  for (auto& p : far.points) p += Eigen::Vector3d(10, 0, 0);
  EXPECT_THROW(register_icp(far, points, Rigid3d::Identity(), options), Error);
  EXPECT_THROW(icp_method_from_string("gicp-best"), Error);
  options.max_iterations = 0;
  EXPECT_THROW(register_icp(points, points, Rigid3d::Identity(), options), Error);
}

// prepare_surface on a cloud sampled from a panorama grid (RegistrationCloud::grid_cells): each
// point's neighbours come from its pixel window. On the furnished room (noise 2 mm along the ray,
// H = 96) the normals are as close to the true faces' as the kd-tree's, and closer at grazing angles,
// where the kd-tree's nearest points collapse onto one pixel row. Bad grids are named errors.
TEST(SurfacePreparation, ThePanoramaWindowGivesNormalsAsGoodAsTheKdTree) {
  const Scene scene = furnished_room();
  const Renderer renderer(scene);
  const Equirectangular pano{96};
  const Rigid3d world_from_pano = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.3, 1.3));
  const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
  RegistrationCloud organised;
  organised.grid_width = pano.width();
  organised.grid_height = pano.height;
  std::vector<Eigen::Vector3d> true_normals;
  std::vector<double> incidence;
  RandomStream rng(3, 0, 0, RandomPurpose::kGeneric);
  for (int v = 0; v < pano.height; ++v)
    for (int u = 0; u < pano.width(); ++u) {
      const double depth = view.depth.at(u, v);
      const int triangle = view.triangle_id.at(u, v);
      if (depth <= 0.3 || triangle < 0) continue;
      organised.points.push_back(pano.direction(u, v) * (depth + 0.002 * rng.normal()));
      organised.grid_cells.push_back(std::uint32_t(v * pano.width() + u));
      const Eigen::Vector3i& t = scene.mesh.triangles[std::size_t(triangle)];
      const Eigen::Vector3d a = scene.mesh.vertices[t[0]].cast<double>(), b = scene.mesh.vertices[t[1]].cast<double>(),
                            c = scene.mesh.vertices[t[2]].cast<double>();
      true_normals.push_back((b - a).cross(c - a).normalized());  // world = panorama axes (no rotation)
      incidence.push_back(view.incidence_cos.at(u, v));
    }
  RegistrationCloud unorganised = organised;
  unorganised.grid_cells.clear();
  RegistrationCloud scalar_window = organised;
  prepare_surface(organised, Eigen::Vector3d::Zero(), SurfaceOptions{});
  prepare_surface(unorganised, Eigen::Vector3d::Zero(), SurfaceOptions{});
  // The vector window (AVX-512, where the CPU has it) and the scalar reference give the same bits.
  SurfaceOptions scalar_options;
  scalar_options.vector_kernels = false;
  prepare_surface(scalar_window, Eigen::Vector3d::Zero(), scalar_options);
  for (std::size_t i = 0; i < organised.points.size(); ++i) {
    ASSERT_EQ(organised.normals[i], scalar_window.normals[i]) << i;
    ASSERT_EQ(organised.curvature[i], scalar_window.curvature[i]) << i;
    ASSERT_EQ(organised.surface_covariances[i], scalar_window.surface_covariances[i]) << i;
  }
  // Median angle (deg) to the true face over all points, and over those seen at grazing angles.
  auto median_error = [&](const RegistrationCloud& cloud, double max_incidence) {
    std::vector<double> errors;
    for (std::size_t i = 0; i < cloud.points.size(); ++i)
      if (incidence[i] <= max_incidence)
        errors.push_back(rad2deg(std::acos(std::min(1.0, std::abs(cloud.normals[i].dot(true_normals[i]))))));
    std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
    return errors[errors.size() / 2];
  };
  const double grid_all = median_error(organised, 1.0), tree_all = median_error(unorganised, 1.0);
  const double grid_grazing = median_error(organised, 0.3), tree_grazing = median_error(unorganised, 0.3);
  std::printf("median normal error: window %.2f deg, kd-tree %.2f deg; grazing (cos <= 0.3) %.2f vs %.2f deg\n",
              grid_all, tree_all, grid_grazing, tree_grazing);
  EXPECT_LT(grid_all, 1.1 * tree_all + 0.1);
  EXPECT_LT(grid_grazing, tree_grazing);
  // Every normal faces the viewpoint, as with the kd-tree.
  for (std::size_t i = 0; i < organised.points.size(); ++i)
    ASSERT_LE(organised.normals[i].dot(organised.points[i]), 0.0) << i;

  RegistrationCloud bad = organised;
  bad.grid_cells.pop_back();
  EXPECT_THROW(prepare_surface(bad, Eigen::Vector3d::Zero(), SurfaceOptions{}), Error);
  bad = organised;
  bad.grid_cells[1] = bad.grid_cells[0];
  try {
    prepare_surface(bad, Eigen::Vector3d::Zero(), SurfaceOptions{});
    FAIL() << "two points in one cell were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("grid_cells"), std::string::npos) << e.what();
  }
  bad = organised;
  bad.grid_cells[0] = std::uint32_t(pano.width() * pano.height);
  EXPECT_THROW(prepare_surface(bad, Eigen::Vector3d::Zero(), SurfaceOptions{}), Error);
  bad = organised;
  bad.grid_width = 0;
  EXPECT_THROW(prepare_surface(bad, Eigen::Vector3d::Zero(), SurfaceOptions{}), Error);
}

// prepare_surface's closed-form eigen-solve against Eigen's iterative one. With k as large as the
// cloud, every point's neighbourhood is the whole cloud, so all share one covariance: random
// anisotropic blobs (plane-like to round) must give Eigen's smallest eigenvector as the normal and its
// eigenvalues' ratio as the curvature; a line of points a normal across the line; one repeated point
// the direction to the viewpoint; and the surface covariance is Segal et al.'s I - (1 - eps) n n^T.
TEST(SurfacePreparation, ClosedFormEigenSolveAgreesWithEigensIterativeOne) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  const Eigen::Vector3d viewpoint(0.3, -2.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    // Axis scales from 1 cm down to 1e-5 cm across the surface, in a random frame.
    const Eigen::Vector3d scales(0.01, 0.01 * std::pow(0.3, trial % 4), 0.01 * std::pow(0.1, trial % 6));
    const Eigen::Matrix3d frame = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    RegistrationCloud cloud;
    const Eigen::Vector3d centre(1.0 + 0.1 * trial, 0.5, -0.2);
    for (int i = 0; i < 20; ++i)
      cloud.points.push_back(centre +
                             frame * scales.cwiseProduct(Eigen::Vector3d(normal(rng), normal(rng), normal(rng))));
    SurfaceOptions options;
    options.neighbours = 20;
    prepare_surface(cloud, viewpoint, options);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : cloud.points) mean += p / 20.0;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& p : cloud.points) covariance += (p - mean) * (p - mean).transpose() / 20.0;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> reference(covariance);
    const Eigen::Vector3d expected_normal = reference.eigenvectors().col(0);
    const double gap = (reference.eigenvalues()[1] - reference.eigenvalues()[0]) / reference.eigenvalues()[2];
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      const Eigen::Vector3d& n = cloud.normals[i];
      EXPECT_NEAR(n.norm(), 1.0, 1e-12);
      EXPECT_GE(n.dot(viewpoint - cloud.points[i]), 0.0) << "trial " << trial;
      if (gap > 1e-3) {
        EXPECT_GT(std::abs(n.dot(expected_normal)), 1.0 - 1e-9) << "trial " << trial << " gap " << gap;
      }
      EXPECT_NEAR(cloud.curvature[i], reference.eigenvalues()[0] / reference.eigenvalues().sum(), 1e-6);
      const Eigen::Matrix3d segal = Eigen::Matrix3d::Identity() - (1.0 - options.plane_epsilon) * n * n.transpose();
      EXPECT_LT((cloud.surface_covariances[i] - segal).norm(), 1e-12);
    }
  }
  // Collinear points: the normal is some direction across the line.
  RegistrationCloud line;
  for (int i = 0; i < 10; ++i)
    line.points.push_back(Eigen::Vector3d(1, 2, 0.5) + 0.01 * i * Eigen::Vector3d(1, 2, 2) / 3);
  prepare_surface(line, viewpoint, SurfaceOptions{});
  for (const Eigen::Vector3d& n : line.normals) {
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    EXPECT_LT(std::abs(n.dot(Eigen::Vector3d(1, 2, 2) / 3)), 1e-6);  // rounding of a rank-1 covariance
  }
  // One point repeated: no shape at all, the normal faces the viewpoint.
  RegistrationCloud repeated;
  repeated.points.assign(5, Eigen::Vector3d(1, 1, 1));
  prepare_surface(repeated, viewpoint, SurfaceOptions{});
  for (const Eigen::Vector3d& n : repeated.normals)
    EXPECT_LT((n - (viewpoint - Eigen::Vector3d(1, 1, 1)).normalized()).norm(), 1e-12);
}

TEST(FeatureAlignment, OrbGuessThenIcpRecoversTheTransformBetweenTwoOfficePositions) {
  // Panoramas of the office from SO-1 and SO-3 (1.6 m apart), at the sensors' height, the source
  // turned by 40 degrees: ORB + 3D RANSAC gives the initial guess, GICP refines it.
  const Scene scene = scenes::make_builtin_scene("office");
  const Renderer renderer(scene);
  const Equirectangular pano{384};
  auto pose_at = [&](int position, double yaw) {
    return make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                      scene.positions[position].floor_point + Eigen::Vector3d(0, 0, 1.1));
  };
  const Rigid3d world_from_target = pose_at(0, 0.0), world_from_source = pose_at(2, deg2rad(40));
  const RenderedView target_view = renderer.render_equirectangular(world_from_target, pano);
  const RenderedView source_view = renderer.render_equirectangular(world_from_source, pano);
  const Rigid3d truth = world_from_target.inverse() * world_from_source;

  const FeatureAlignment guess = align_panorama_features(
      {&source_view.rgb, &source_view.depth}, {&target_view.rgb, &target_view.depth}, FeatureAlignmentOptions{});
  ASSERT_TRUE(guess.success) << guess.failure;
  std::printf("ORB: %d/%d features, %d matches, %d inliers; guess error %.3f deg, %.1f mm\n", guess.source_features,
              guess.target_features, guess.matches, guess.inliers, rotation_error_deg(guess.target_from_source, truth),
              (guess.target_from_source.translation() - truth.translation()).norm() * 1e3);
  EXPECT_LT(rotation_error_deg(guess.target_from_source, truth), 2.0);
  EXPECT_LT((guess.target_from_source.translation() - truth.translation()).norm(), 0.05);

  auto cloud_of = [&](const RenderedView& view) {
    RegistrationCloud cloud;
    for (int v = 0; v < pano.height; v += 2)
      for (int u = 0; u < pano.width(); u += 2)
        if (view.depth.at(u, v) > 0) cloud.points.push_back(pano.direction(u, v) * double(view.depth.at(u, v)));
    prepare_surface(cloud, Eigen::Vector3d::Zero(), SurfaceOptions{});
    return cloud;
  };
  const RegistrationCloud source = cloud_of(source_view), target = cloud_of(target_view);
  IcpOptions options;
  options.method = IcpMethod::kGicp;
  const IcpResult refined = register_icp(source, target, guess.target_from_source, options);
  EXPECT_LT(rotation_error_deg(refined.target_from_source, truth), 0.1);
  EXPECT_LT((refined.target_from_source.translation() - truth.translation()).norm(), 0.005);

  // A deliberately bad guess (turned by 90 degrees) converges to a wrong minimum that still
  // finds walls everywhere (fitness 0.50 against 0.76 at the truth): the feature matches, not
  // the geometry, expose it.
  EXPECT_GE(count_consistent_matches(guess, refined.target_from_source, 0.05), guess.inliers * 9 / 10);
  const Rigid3d bad =
      make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())), Eigen::Vector3d::Zero()) *
      truth;
  const IcpResult wrong = register_icp(source, target, bad, options);
  EXPECT_GT(rotation_error_deg(wrong.target_from_source, truth), 45.0);  // the wrong minimum
  EXPECT_LT(count_consistent_matches(guess, wrong.target_from_source, 0.05), guess.inliers / 5);
}

TEST(FeatureAlignment, FeaturelessPanoramasReportFailure) {
  ImageU8 grey(256, 128, 3, 128);
  ImageF32 depth(256, 128, 1, 2.0f);
  const FeatureAlignment result = align_panorama_features({&grey, &depth}, {&grey, &depth}, FeatureAlignmentOptions{});
  EXPECT_FALSE(result.success);
  EXPECT_FALSE(result.failure.empty());
  ImageU8 wrong_size(100, 100, 3, 0);
  EXPECT_THROW(align_panorama_features({&wrong_size, &depth}, {&grey, &depth}, FeatureAlignmentOptions{}), Error);
}

TEST(OutsideReference, Open3dAndPclGicpAgreeOnTheSameClouds) {
  const Scene scene = furnished_room();
  const Renderer renderer(scene);
  const Rigid3d world_from_target = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, -0.3, 1.2));
  const Rigid3d world_from_source = make_rigid(so3_exp(Eigen::Vector3d(0.0, 0.0, 0.5)), Eigen::Vector3d(0.8, 0.2, 1.2));
  const Panorama target = make_panorama(renderer, world_from_target, 0.002, 0.002, 1);
  const Panorama source = make_panorama(renderer, world_from_source, 0.002, 0.002, 2);
  const Rigid3d truth = world_from_target.inverse() * world_from_source;
  const Rigid3d initial =
      make_rigid(so3_exp(Eigen::Vector3d(0.0, 0.01, 0.03)), Eigen::Vector3d(0.03, -0.02, 0.01)) * truth;
  const IcpResult reference = register_open3d_gicp(source.cloud, target.cloud, initial, IcpOptions{});
  EXPECT_LT(rotation_error_deg(reference.target_from_source, truth), 0.1);
  EXPECT_LT((reference.target_from_source.translation() - truth.translation()).norm(), 0.005);
  EXPECT_GT(reference.inlier_fraction, 0.5);
  const IcpResult pcl = register_pcl_gicp(source.cloud, target.cloud, initial, IcpOptions{});
  EXPECT_TRUE(pcl.converged);
  EXPECT_LT(rotation_error_deg(pcl.target_from_source, truth), 0.1);
  EXPECT_LT((pcl.target_from_source.translation() - truth.translation()).norm(), 0.005);
}
