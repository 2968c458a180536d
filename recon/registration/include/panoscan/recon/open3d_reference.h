// Open3D's Generalized-ICP on the same clouds, as the outside reference of Table 4 and of the
// registration speed benchmark (Open3D computes its own covariances from 20 neighbours).
#pragma once

#include "panoscan/recon/registration.h"

namespace panoscan {

// Uses options.max_correspondence_m and options.max_iterations. The result carries the pose and
// what Open3D reports: inlier_fraction (its "fitness", within max_correspondence_m) and rmse_m
// over those inliers; Open3D 0.16 does not report the iteration count (iterations = the cap).
IcpResult register_open3d_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                               const Rigid3d& initial_target_from_source, const IcpOptions& options);

}  // namespace panoscan
