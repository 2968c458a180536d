// Registration error: a known pose error, and the registered cloud's RMSE against the mesh with
// the true pose as its noise floor.

#include <cmath>

#include <gtest/gtest.h>

#include "panoscan/core/geometry.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/eval/registration_metrics.h"
#include "panoscan/eval/surface_sampling.h"

namespace panoscan::eval {
namespace {

TriangleMesh room() {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) mesh.vertices.emplace_back(i & 1 ? 4.f : 0.f, i & 2 ? 3.f : 0.f, i & 4 ? 2.5f : 0.f);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.triangles.emplace_back(q[0], q[1], q[2]);
    mesh.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return mesh;
}

TEST(Registration, PoseErrorAndRegisteredCloudAccuracy) {
  const TriangleMesh mesh = room();
  const MeshDistance distance(mesh);
  const Rigid3d world_from_target = make_rigid(so3_exp(Eigen::Vector3d(0, 0, 0.4)), Eigen::Vector3d(1.5, 1.2, 1.1));
  const Rigid3d target_from_source = make_rigid(so3_exp(Eigen::Vector3d(0, 0, -1.2)), Eigen::Vector3d(0.8, -0.3, 0.02));
  // The source cloud: exact surface samples, expressed in the source frame.
  PointCloud source;
  const Rigid3d source_from_world = (world_from_target * target_from_source).inverse();
  for (const SurfaceSample& s : sample_surface_uniform(mesh, 5000, 1))
    source.positions.push_back(source_from_world * s.point);

  CloudMetricsOptions options;
  options.completeness.enabled = false;
  const RegistrationMetrics exact = evaluate_registration(target_from_source, target_from_source, world_from_target,
                                                          source, distance, options, "src");
  EXPECT_NEAR(exact.pose.rotation_deg, 0.0, 1e-9);
  EXPECT_LT(exact.registered.accuracy_m.rmse, 1e-9);
  EXPECT_LT(exact.with_true_pose_m.rmse, 1e-9);

  // 1 deg about z and 5 mm along x (in the target frame): the registered cloud is off by mm.
  Rigid3d estimate = rotation_about(Eigen::Vector3d::UnitZ(), deg2rad(1.0)) * target_from_source;
  estimate.translation() += Eigen::Vector3d(0.005, 0, 0);
  const RegistrationMetrics off =
      evaluate_registration(estimate, target_from_source, world_from_target, source, distance, options, "src");
  EXPECT_NEAR(off.pose.rotation_deg, 1.0, 1e-9);
  EXPECT_NEAR(off.pose.translation_m, (estimate.translation() - target_from_source.translation()).norm(), 1e-12);
  EXPECT_GT(off.registered.accuracy_m.rmse, 0.002);
  EXPECT_LT(off.registered.accuracy_m.rmse, 0.06);
  EXPECT_LT(off.with_true_pose_m.rmse, 1e-9);
}

}  // namespace
}  // namespace panoscan::eval
