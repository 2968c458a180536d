#include "panoscan/recon/outside_references.h"

#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/GeneralizedICP.h>

#include "panoscan/core/error.h"

namespace panoscan {

IcpResult register_open3d_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                               const Rigid3d& initial_target_from_source, const IcpOptions& options) {
  options.check();
  if (source.points.empty() || target.points.empty()) throw make_error("", "registration", "empty cloud");
  open3d::geometry::PointCloud open3d_source, open3d_target;
  open3d_source.points_ = source.points;
  open3d_target.points_ = target.points;
  namespace reg = open3d::pipelines::registration;
  const reg::RegistrationResult open3d_result = reg::RegistrationGeneralizedICP(
      open3d_source, open3d_target, options.max_correspondence_m, initial_target_from_source.matrix(),
      reg::TransformationEstimationForGeneralizedICP(),
      reg::ICPConvergenceCriteria(1e-6, 1e-6, options.max_iterations));
  IcpResult result;
  result.target_from_source.matrix() = open3d_result.transformation_;
  result.iterations = options.max_iterations;  // Open3D 0.16 does not report the count
  result.converged = true;
  result.inlier_fraction = open3d_result.fitness_;
  result.correspondences = open3d_result.correspondence_set_.size();
  result.rmse_m = open3d_result.inlier_rmse_;
  return result;
}

}  // namespace panoscan
