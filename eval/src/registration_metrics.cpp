#include "panoscan/eval/registration_metrics.h"

#include "panoscan/eval/mesh_distance.h"

namespace panoscan::eval {

namespace {

PointCloud transformed(const PointCloud& cloud, const Rigid3d& b_from_a) {
  PointCloud out = cloud;
  for (auto& p : out.positions) p = b_from_a * p;
  for (auto& n : out.normals) n = (b_from_a.linear() * n.cast<double>()).cast<float>();
  return out;
}

}  // namespace

RegistrationMetrics evaluate_registration(const Rigid3d& estimated_target_from_source,
                                          const Rigid3d& true_target_from_source, const Rigid3d& world_from_target_true,
                                          const PointCloud& source_in_source, const MeshDistance& mesh,
                                          const CloudMetricsOptions& options, const std::string& source_origin) {
  RegistrationMetrics metrics;
  metrics.pose = pose_error(estimated_target_from_source, true_target_from_source);
  const PointCloud registered = transformed(source_in_source, world_from_target_true * estimated_target_from_source);
  metrics.registered = evaluate_cloud(mesh, registered, source_origin, options);
  const PointCloud reference = transformed(source_in_source, world_from_target_true * true_target_from_source);
  metrics.with_true_pose_m = summarize_errors(mesh.distances(reference.positions, source_origin));
  return metrics;
}

}  // namespace panoscan::eval
