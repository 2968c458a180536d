// The factors of the joint tracking (recon/tracking/src/tracking_factors.h, Eq. 1-3 and the priors):
// each cost function's Jacobians against central differences (along the quaternion manifold where
// a block is a rotation), at random parameter values, and the
// residuals of Eq. 1 and Eq. 2 against their definitions written with Eigen.
#include <memory>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <ceres/manifold.h>

#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "tracking_factors.h"

namespace panoscan {
namespace {

namespace tf = tracking_factors;

struct Block {
  std::vector<double> values;
  bool quaternion = false;
};

Block random_quaternion(RandomStream& rng) {
  Eigen::Quaterniond q(so3_exp(Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()) * 0.7));
  return {{q.w(), q.x(), q.y(), q.z()}, true};
}
Block random_vector(RandomStream& rng, int n, double scale) {
  Block b;
  for (int k = 0; k < n; ++k) b.values.push_back(scale * rng.normal());
  return b;
}

Block quaternion_block(const Rigid3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  return {{q.w(), q.x(), q.y(), q.z()}, true};
}
Block translation_block(const Rigid3d& pose) {
  return {{pose.translation().x(), pose.translation().y(), pose.translation().z()}, false};
}
Rigid3d random_pose(RandomStream& rng, double rotation_rad, double translation_m) {
  return make_rigid(so3_exp(rotation_rad * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal())),
                    translation_m * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()));
}
// The Eq. 2 model pose T_u R(alpha) T_u^-1 T_r T_c.
Rigid3d model_pose(const Rigid3d& axis, double alpha, const Rigid3d& rig, const Rigid3d& extrinsics) {
  return axis * rotation_about(Eigen::Vector3d::UnitZ(), alpha) * axis.inverse() * rig * extrinsics;
}

// Jacobians of `cost` at `blocks`, in each block's tangent space (ambient Jacobian times the
// QuaternionManifold's PlusJacobian for rotations), against central differences taken along the
// manifold (Plus(x, +-h e_j)): |analytic - numeric| <= 1e-6 (1 + the block's largest entry).
// (ceres::GradientChecker differentiates in the ambient space; on one state of Eq. 2 its
// difference quotient for the extrinsics' rotation was 3e-4 off the analytic Jacobian where these
// differences along the manifold agree to 1e-8, so the check is written out here.)
void expect_jacobians_match_numeric(ceres::CostFunction* cost_raw, const std::vector<Block>& blocks, const char* name) {
  std::unique_ptr<ceres::CostFunction> cost(cost_raw);
  const ceres::QuaternionManifold quaternion;
  const int residuals = cost->num_residuals();
  std::vector<const double*> parameters;
  std::vector<std::vector<double>> ambient(blocks.size());
  std::vector<double*> jacobians;
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    parameters.push_back(blocks[k].values.data());
    ambient[k].resize(std::size_t(residuals) * blocks[k].values.size());
    jacobians.push_back(ambient[k].data());
  }
  std::vector<double> r0(residuals);
  ASSERT_TRUE(cost->Evaluate(parameters.data(), r0.data(), jacobians.data())) << name;
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const int size = int(blocks[k].values.size());
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> j_ambient(
        ambient[k].data(), residuals, size);
    Eigen::MatrixXd analytic = j_ambient;
    const int tangent = blocks[k].quaternion ? 3 : size;
    if (blocks[k].quaternion) {
      Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus_jacobian;
      quaternion.PlusJacobian(blocks[k].values.data(), plus_jacobian.data());
      analytic = j_ambient * plus_jacobian;
    }
    Eigen::MatrixXd numeric(residuals, tangent);
    for (int j = 0; j < tangent; ++j) {
      const double h = 1e-6;
      std::vector<double> plus = blocks[k].values, minus = blocks[k].values;
      if (blocks[k].quaternion) {
        double delta[3] = {0, 0, 0};
        delta[j] = h;
        quaternion.Plus(blocks[k].values.data(), delta, plus.data());
        delta[j] = -h;
        quaternion.Plus(blocks[k].values.data(), delta, minus.data());
      } else {
        plus[j] += h;
        minus[j] -= h;
      }
      std::vector<const double*> at_plus = parameters, at_minus = parameters;
      at_plus[k] = plus.data();
      at_minus[k] = minus.data();
      std::vector<double> r_plus(residuals), r_minus(residuals);
      ASSERT_TRUE(cost->Evaluate(at_plus.data(), r_plus.data(), nullptr)) << name;
      ASSERT_TRUE(cost->Evaluate(at_minus.data(), r_minus.data(), nullptr)) << name;
      for (int r = 0; r < residuals; ++r) numeric(r, j) = (r_plus[r] - r_minus[r]) / (2 * h);
    }
    const double scale = 1.0 + numeric.cwiseAbs().maxCoeff();
    EXPECT_LE((analytic - numeric).cwiseAbs().maxCoeff(), 1e-6 * scale)
        << name << ", parameter block " << k << "\nanalytic\n"
        << analytic << "\nnumeric\n"
        << numeric;
  }
}

// The observation factor's closed-form Jacobians (tracking_factors.h: ObservationJacobian) against
// the auto-differentiated functor they replace: the same residuals and the same Jacobians in the
// manifold's tangent space (the ambient ones may differ along q, which the manifold never moves).
TEST(TrackingFactors, ObservationClosedFormEqualsItsAutoDiffReference) {
  RandomStream rng(5, 0, 0, RandomPurpose::kGeneric);
  const ceres::QuaternionManifold manifold;
  for (int trial = 0; trial < 50; ++trial) {
    Block q = random_quaternion(rng);
    if (trial % 5 == 4)  // not quite unit, as after many manifold steps
      for (double& c : q.values) c *= 1.0 + 1e-6 * rng.normal();
    const Block t = random_vector(rng, 3, 1.0), y = random_vector(rng, 3, 3.0);
    // Far and near, in front and (first iterations) behind the camera.
    const double u = 320 + 200 * rng.normal(), v = 240 + 150 * rng.normal(), d = 0.5 + 4 * rng.uniform();
    std::unique_ptr<ceres::CostFunction> closed(tf::ObservationCost::create(u, v, d, 525, 520, 319.5, 239.5, 1.3, 0.01));
    std::unique_ptr<ceres::CostFunction> reference(
        tf::ObservationCost::create_autodiff(u, v, d, 525, 520, 319.5, 239.5, 1.3, 0.01));
    const double* parameters[3] = {q.values.data(), t.values.data(), y.values.data()};
    double r_closed[3], r_reference[3];
    double jc[3][12], jr[3][12];
    double* j_closed[3] = {jc[0], jc[1], jc[2]};
    double* j_reference[3] = {jr[0], jr[1], jr[2]};
    ASSERT_TRUE(closed->Evaluate(parameters, r_closed, j_closed));
    ASSERT_TRUE(reference->Evaluate(parameters, r_reference, j_reference));
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(r_closed[r], r_reference[r], 1e-9 * (1 + std::abs(r_reference[r])));
    Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus;
    manifold.PlusJacobian(q.values.data(), plus.data());
    using Ambient = Eigen::Map<const Eigen::Matrix<double, 3, 4, Eigen::RowMajor>>;
    const Eigen::Matrix3d tangent_closed = Ambient(jc[0]) * plus, tangent_reference = Ambient(jr[0]) * plus;
    const double scale = 1 + tangent_reference.cwiseAbs().maxCoeff();
    EXPECT_LE((tangent_closed - tangent_reference).cwiseAbs().maxCoeff(), 1e-9 * scale) << "trial " << trial;
    for (int k = 1; k < 3; ++k)
      for (int e = 0; e < 9; ++e) EXPECT_NEAR(jc[k][e], jr[k][e], 1e-9 * scale) << "block " << k;
  }
}

TEST(TrackingFactors, EveryFactorsJacobianMatchesNumericDifferentiation) {
  RandomStream rng(11, 0, 0, RandomPurpose::kGeneric);
  for (int trial = 0; trial < 10; ++trial) {
    auto q = [&] { return random_quaternion(rng); };
    auto t = [&] { return random_vector(rng, 3, 0.5); };
    auto a = [&] { return random_vector(rng, 1, 2.0); };
    // Eq. 1: a landmark in front of the camera.
    const Block q_cam = q(), t_cam = t();
    const Rigid3d world_from_cam = make_rigid(
        Eigen::Quaterniond(q_cam.values[0], q_cam.values[1], q_cam.values[2], q_cam.values[3]).toRotationMatrix(),
        Eigen::Vector3d(t_cam.values[0], t_cam.values[1], t_cam.values[2]));
    const Eigen::Vector3d landmark = world_from_cam * Eigen::Vector3d(0.3 * rng.normal(), 0.3 * rng.normal(), 2.5);
    expect_jacobians_match_numeric(
        tf::ObservationCost::create(170 + rng.normal(), 110 + rng.normal(), 2.4, 285, 285, 160, 120, 1.2, 0.006),
        {q_cam, t_cam, {{landmark.x(), landmark.y(), landmark.z()}, false}}, "observation (Eq. 1)");
    // Eq. 2 and the shared wobble where they act: frames near the model (a deviation of the
    // wobble's size), the axis, rig and extrinsics anywhere. (Far from it the error rotation can
    // reach pi, where a rotation vector is not differentiable.)
    const Rigid3d axis = random_pose(rng, 0.7, 0.5), rig = random_pose(rng, 0.7, 0.5);
    const Rigid3d extr_a = random_pose(rng, 0.7, 0.1), extr_b = random_pose(rng, 0.7, 0.1);
    const double alpha_a = 6.0 * rng.uniform(), alpha_b = alpha_a + 0.01;
    const Rigid3d cam_a = model_pose(axis, alpha_a, rig, extr_a) * random_pose(rng, 0.01, 0.005);
    const Rigid3d cam_b = model_pose(axis, alpha_b, rig, extr_b) * random_pose(rng, 0.01, 0.005);
    expect_jacobians_match_numeric(tf::RegularisationCost::create(0.005, 0.0087),
                                   {quaternion_block(cam_a),
                                    translation_block(cam_a),
                                    {{alpha_a}, false},
                                    quaternion_block(axis),
                                    translation_block(axis),
                                    quaternion_block(rig),
                                    translation_block(rig),
                                    quaternion_block(extr_a),
                                    translation_block(extr_a)},
                                   "pose regularisation (Eq. 2)");
    expect_jacobians_match_numeric(tf::SharedWobbleCost::create(0.003, 0.005),
                                   {quaternion_block(cam_a),
                                    translation_block(cam_a),
                                    {{alpha_a}, false},
                                    quaternion_block(extr_a),
                                    translation_block(extr_a),
                                    quaternion_block(cam_b),
                                    translation_block(cam_b),
                                    {{alpha_b}, false},
                                    quaternion_block(extr_b),
                                    translation_block(extr_b),
                                    quaternion_block(axis),
                                    translation_block(axis),
                                    quaternion_block(rig),
                                    translation_block(rig)},
                                   "shared wobble");
    expect_jacobians_match_numeric(tf::VelocityCost::create(0.0, 0.52, 1.07, 0.0087), {a(), a(), a()},
                                   "velocity smoothness (Eq. 3)");
    expect_jacobians_match_numeric(tf::SameTimeCost::create(1e-3), {a(), a()}, "same time");
    // The priors near their prior value (their use: a calibration a few degrees off at most).
    const Rigid3d prior = random_pose(rng, 0.7, 0.1), near_prior = prior * random_pose(rng, 0.05, 0.01);
    const Block prior_q = quaternion_block(prior), prior_t = translation_block(prior);
    expect_jacobians_match_numeric(tf::PosePriorCost::create(prior_q.values.data(), prior_t.values.data(), 0.01, 0.017),
                                   {quaternion_block(near_prior), translation_block(near_prior)}, "pose prior");
    expect_jacobians_match_numeric(
        tf::ExtrinsicsNullPriorCost::create(prior_q.values.data(), prior_t.values.data(), 1e-3, 1e-3),
        {quaternion_block(near_prior), translation_block(near_prior), quaternion_block(axis), quaternion_block(rig)},
        "extrinsics null-space prior");
    // The depth odometry's relative pose (beyond the paper), near its measurement, with a full
    // (correlated) square-root information.
    const Rigid3d frame_a = random_pose(rng, 0.7, 0.5), a_from_b = random_pose(rng, 0.1, 0.05);
    const Rigid3d frame_b = frame_a * a_from_b * random_pose(rng, 0.01, 0.005);
    const Block measured_q = quaternion_block(a_from_b), measured_t = translation_block(a_from_b);
    std::vector<double> root(36);
    for (double& x : root) x = 100.0 * rng.normal();
    expect_jacobians_match_numeric(
        tf::RelativePoseCost::create(measured_q.values.data(), measured_t.values.data(), root.data()),
        {quaternion_block(frame_a), translation_block(frame_a), quaternion_block(frame_b), translation_block(frame_b)},
        "depth odometry (relative pose)");
  }
}

TEST(TrackingFactors, RelativePoseResidualIsTheWhitenedRightPerturbation) {
  // Frame b exactly where the measurement puts it: zero residual. Then b moved by a small right
  // perturbation (omega, v) in b's frame, the ICP's parametrisation: the residual is S (omega, v).
  const Rigid3d frame_a = make_rigid(so3_exp(Eigen::Vector3d(0.1, 1.2, -0.2)), Eigen::Vector3d(0.3, -0.1, 1.2));
  const Rigid3d a_from_b = make_rigid(so3_exp(Eigen::Vector3d(0.0, 0.1, 0.01)), Eigen::Vector3d(0.02, 0.0, -0.01));
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> root = Eigen::Matrix<double, 6, 6>::Identity() * 50.0;
  root(0, 4) = 20.0;  // a correlation between the rotation about x and the slide along y
  const Block mq = quaternion_block(a_from_b), mt = translation_block(a_from_b);
  std::unique_ptr<ceres::CostFunction> cost(tf::RelativePoseCost::create(mq.values.data(), mt.values.data(), root.data()));
  auto evaluate = [&](const Rigid3d& frame_b) {
    const Block qa = quaternion_block(frame_a), ta = translation_block(frame_a);
    const Block qb = quaternion_block(frame_b), tb = translation_block(frame_b);
    const double* parameters[] = {qa.values.data(), ta.values.data(), qb.values.data(), tb.values.data()};
    Eigen::Matrix<double, 6, 1> residual;
    EXPECT_TRUE(cost->Evaluate(parameters, residual.data(), nullptr));
    return residual;
  };
  EXPECT_LT(evaluate(frame_a * a_from_b).norm(), 1e-9);
  Eigen::Matrix<double, 6, 1> delta;
  delta << 1e-4, -2e-4, 3e-4, 1e-4, 2e-4, -5e-5;
  const Rigid3d perturbed = frame_a * a_from_b * make_rigid(so3_exp(delta.head<3>()), delta.tail<3>());
  const Eigen::Matrix<double, 6, 1> expected = root * delta;
  EXPECT_LT((evaluate(perturbed) - expected).norm(), 1e-6 * expected.norm());
}

TEST(TrackingFactors, ObservationAndRegularisationResidualsVanishAtAConsistentState) {
  // Eq. 1: the landmark projected exactly where it is observed, at the observed depth.
  const Rigid3d world_from_cam = make_rigid(so3_exp(Eigen::Vector3d(0.1, -0.3, 0.8)), Eigen::Vector3d(0.2, 0.1, 1.1));
  const Eigen::Vector3d in_camera(0.4, -0.2, 2.0);
  const Eigen::Vector3d landmark = world_from_cam * in_camera;
  const double fx = 285, fy = 286, cx = 160, cy = 120;
  const double u = fx * in_camera.x() / in_camera.z() + cx, v = fy * in_camera.y() / in_camera.z() + cy;
  std::unique_ptr<ceres::CostFunction> observation(
      tf::ObservationCost::create(u, v, in_camera.z(), fx, fy, cx, cy, 1.0, 0.004));
  const Eigen::Quaterniond q(world_from_cam.linear());
  const double qc[4] = {q.w(), q.x(), q.y(), q.z()};
  const double tc[3] = {world_from_cam.translation().x(), world_from_cam.translation().y(),
                        world_from_cam.translation().z()};
  const double y[3] = {landmark.x(), landmark.y(), landmark.z()};
  const double* parameters[] = {qc, tc, y};
  double residual[6];
  ASSERT_TRUE(observation->Evaluate(parameters, residual, nullptr));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(residual[k], 0.0, 1e-9);
  // ... and a depth 1 cm off gives (d - Z) / sigma_d in the third component.
  std::unique_ptr<ceres::CostFunction> off(
      tf::ObservationCost::create(u, v, in_camera.z() + 0.01, fx, fy, cx, cy, 1.0, 0.004));
  ASSERT_TRUE(off->Evaluate(parameters, residual, nullptr));
  EXPECT_NEAR(residual[2], 0.01 / 0.004, 1e-9);

  // Eq. 2: the camera exactly at T_u R(alpha) T_u^-1 T_r T_c.
  const Rigid3d world_from_axis =
      make_rigid(so3_exp(Eigen::Vector3d(0.02, -0.01, 0.3)), Eigen::Vector3d(0.1, 0.0, 1.0));
  const Rigid3d world_from_rig = make_rigid(so3_exp(Eigen::Vector3d(0.0, 0.01, 0.0)), Eigen::Vector3d(0.0, 0.01, 0.0));
  const Rigid3d ref_from_cam = make_rigid(so3_exp(Eigen::Vector3d(0.78, 0, 0)), Eigen::Vector3d(0, 0.06, 0.02));
  const double alpha = 1.3;
  const Rigid3d model = world_from_axis * rotation_about(Eigen::Vector3d::UnitZ(), alpha) * world_from_axis.inverse() *
                        world_from_rig * ref_from_cam;
  auto blocks = [](const Rigid3d& pose, double* qb, double* tb) {
    const Eigen::Quaterniond qq(pose.linear());
    qb[0] = qq.w(), qb[1] = qq.x(), qb[2] = qq.y(), qb[3] = qq.z();
    for (int k = 0; k < 3; ++k) tb[k] = pose.translation()[k];
  };
  double q_cam[4], t_cam[3], q_axis[4], t_axis[3], q_rig[4], t_rig[3], q_extr[4], t_extr[3];
  blocks(model, q_cam, t_cam);
  blocks(world_from_axis, q_axis, t_axis);
  blocks(world_from_rig, q_rig, t_rig);
  blocks(ref_from_cam, q_extr, t_extr);
  std::unique_ptr<ceres::CostFunction> regularisation(tf::RegularisationCost::create(0.005, 0.0087));
  const double* reg_parameters[] = {q_cam, t_cam, &alpha, q_axis, t_axis, q_rig, t_rig, q_extr, t_extr};
  ASSERT_TRUE(regularisation->Evaluate(reg_parameters, residual, nullptr));
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(residual[k], 0.0, 1e-9);
  // A camera 1 mm off along its own x gives 1 mm / sigma_t in the first component.
  blocks(model * make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.001, 0, 0)), q_cam, t_cam);
  ASSERT_TRUE(regularisation->Evaluate(reg_parameters, residual, nullptr));
  EXPECT_NEAR(std::abs(residual[0]), 0.001 / 0.005, 1e-9);
}

}  // namespace
}  // namespace panoscan
