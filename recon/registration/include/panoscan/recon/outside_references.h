// Outside references for Table 4 and the registration speed benchmark: Open3D's and PCL's
// Generalized-ICP run on the same clouds (each computes its own covariances from its neighbours).
#pragma once

#include "panoscan/recon/registration.h"

namespace panoscan {

// Uses options.max_correspondence_m and options.max_iterations. The result carries the pose and
// what Open3D reports: inlier_fraction (its "fitness", within max_correspondence_m) and rmse_m
// over those inliers; Open3D 0.16 does not report the iteration count (iterations = the cap).
IcpResult register_open3d_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                               const Rigid3d& initial_target_from_source, const IcpOptions& options);

// PCL's GeneralizedIterativeClosestPoint (the paper's own base, single-threaded), with the same
// correspondence distance and iteration cap; inlier_fraction is not reported by PCL (0), rmse_m is
// sqrt of PCL's fitness score (mean squared distance within the correspondence distance).
IcpResult register_pcl_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                            const Rigid3d& initial_target_from_source, const IcpOptions& options);

}  // namespace panoscan
