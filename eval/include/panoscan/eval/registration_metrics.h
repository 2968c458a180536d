// Registration errors (docs/ARCHITECTURE.md §13, paper Table 4): the estimated relative pose against the truth, and
// the accuracy of the source cloud placed by the estimated pose against the ground-truth mesh.
#pragma once

#include <string>

#include "panoscan/core/geometry.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/eval/cloud_metrics.h"
#include "panoscan/eval/pose_error.h"

namespace panoscan::eval {

class MeshDistance;

struct RegistrationMetrics {
  PoseError pose;               // estimated vs true target_from_source
  CloudMetrics registered;      // source placed by the estimate: world_from_target_true * estimate
  ErrorStats with_true_pose_m;  // the same cloud placed by the true pose: its noise floor
};

// `source_in_source` holds the source cloud in its own frame; the ground-truth mesh is in the
// world (scene) frame, where the target sits at `world_from_target_true`.
RegistrationMetrics evaluate_registration(const Rigid3d& estimated_target_from_source,
                                          const Rigid3d& true_target_from_source, const Rigid3d& world_from_target_true,
                                          const PointCloud& source_in_source, const MeshDistance& mesh,
                                          const CloudMetricsOptions& options, const std::string& source_origin);

}  // namespace panoscan::eval
