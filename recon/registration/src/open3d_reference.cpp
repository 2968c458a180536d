#include "panoscan/recon/outside_references.h"

#include "panoscan/core/error.h"
#include "panoscan/recon/open3d_calls.h"

namespace panoscan {

IcpResult register_open3d_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                               const Rigid3d& initial_target_from_source, const IcpOptions& options) {
  options.check();
  if (source.points.empty() || target.points.empty()) throw make_error("", "registration", "empty cloud");
  const open3d_calls::GicpResult open3d_result =
      open3d_calls::generalized_icp(source.points, target.points, options.max_correspondence_m,
                                    initial_target_from_source.matrix(), options.max_iterations);
  IcpResult result;
  result.target_from_source.matrix() = open3d_result.target_from_source;
  result.iterations = options.max_iterations;  // Open3D 0.16 does not report the count
  result.converged = true;
  result.inlier_fraction = open3d_result.fitness;
  result.correspondences = open3d_result.correspondences;
  result.rmse_m = open3d_result.inlier_rmse;
  return result;
}

}  // namespace panoscan
