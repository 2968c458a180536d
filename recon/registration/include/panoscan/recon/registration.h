// Registration between two point clouds (paper §5.1): the ICP family of Table 4 on one code path.
//
// Every method minimises sum_i d_i^T M_i d_i over target_from_source (Gauss-Newton on SE(3),
// left perturbation), d_i = b_i - T a_i for the correspondence (a_i in source, b_i in target);
// the methods differ only in M_i and in how correspondences are chosen:
//   kPointToPoint            M = I                                  (Besl & McKay 1992)
//   kPointToPlane            M = n n^T, n the target normal          (Rusinkiewicz & Levoy 2001)
//   kPointToPlaneCurvature   M = w n n^T, w from the confidence (observation count) and the
//                            curvature of the target point           (Lefloch et al. 2017, "Curv")
//   kGicp                    M = (C_b + R C_a R^T)^-1, C the plane-shaped surface covariances
//                            diag(eps, 1, 1) (Segal et al. 2009, plain GICP)
//   kAnisotropic             as kGicp, but the correspondence is the Mahalanobis-nearest of the
//                            Euclidean candidates                    (Maier-Hein et al. 2012)
//   kGicpNoiseModel          C = C_surf + the Handa model's measurement covariance ("Def.")
//   kGicpMeasured            C = C_surf + J diag(s_phi^2, s_theta^2, s_z^2) J^T with the
//                            per-pixel measured variance (Eq. 9, "Ours")
// The measurement covariances come with the clouds (RegistrationCloud::measurement_covariances);
// which model produced them is the caller's choice (see point_covariance.h).
//
// Determinism: sums are reduced in fixed blocks in a fixed order, so the result does not depend
// on the thread count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"

namespace panoscan {

enum class IcpMethod {
  kPointToPoint,
  kPointToPlane,
  kPointToPlaneCurvature,
  kGicp,
  kAnisotropic,
  kGicpNoiseModel,
  kGicpMeasured,
};

const char* to_string(IcpMethod method);
IcpMethod icp_method_from_string(const std::string& name);  // throws Error listing the names

// A cloud prepared for registration.
struct RegistrationCloud {
  std::vector<Eigen::Vector3d> points;
  // Optional (empty or one per point): the sensor's measurement covariance of each point (m^2),
  // used by kGicpNoiseModel / kGicpMeasured.
  std::vector<Eigen::Matrix3d> measurement_covariances;
  // Optional (empty or one per point): observation count (confidence), used by "Curv".
  std::vector<float> confidence;
  // Optional (empty or one per point): the cell of a grid_width x grid_height grid each point was
  // sampled from (row * grid_width + column; an equirectangular panorama's every stride-th pixel,
  // whose columns wrap around in azimuth). With it prepare_surface takes each point's neighbours
  // from the grid window around its cell (SurfaceOptions::grid_radius) instead of a kd-tree.
  std::vector<std::uint32_t> grid_cells;
  int grid_width = 0, grid_height = 0;

  // Filled by prepare_surface(): unit normals, curvature (lambda_min / sum lambda) and the
  // plane-shaped GICP covariance of each point (m^2).
  std::vector<Eigen::Vector3d> normals;
  std::vector<float> curvature;
  std::vector<Eigen::Matrix3d> surface_covariances;
};

struct SurfaceOptions {
  int neighbours = 20;          // k nearest neighbours for the local plane
  // For a cloud with grid_cells: the k nearest are chosen among the points of the
  // (2 r + 1) x (2 r + 1) grid window around the point, as range-image normal estimation does
  // (KinectFusion; PCL's organised estimators). r = 3: 48 candidates for k = 20. The kd-tree's
  // k nearest in space are nearly the same set on a surface seen face-on; on one seen at a grazing
  // angle (the floor far away) they collapse onto one pixel row, a line whose plane is ill-defined,
  // where the window keeps rows above and below. Cost: a fixed window against a tree descent per
  // point (recon/registration/README.md, "Surface preparation").
  int grid_radius = 3;
  double plane_epsilon = 1e-3;  // GICP's epsilon: normal variance relative to the in-plane ones
  // false (the default): Segal et al.'s unit form U diag(eps, 1, 1) U^T in m^2 (as Open3D's and
  // PCL's GICP), the form the paper names for Eq. 9's surface part; the measurement covariance
  // then reweights the correspondences by a few per cent along the normal (eps = 1e-3 m^2, a 3 cm
  // deviation, against sigma_z of a few mm).
  // true: the shape scaled by the neighbourhood's in-plane variance (m^2; the default before issue
  // 17, "so that the units agree"). The normal variance is then eps times a few mm^2, the measurement
  // covariance dominates, and its angular term (half a pixel: 8 mm at 2.5 m, H = 512) downweights
  // every obliquely seen surface: over seeds 1-6 (quick, SO-13; README "Table 4: what the measured
  // variance does") GICP (Ours) registered 2.5x further from the truth than with the unit form, and
  // worse than plain GICP. Integration (Eq. 10-11) uses the metric form as a position uncertainty.
  bool metric_scale = false;
  int threads = 0;
  // false: the scalar reference paths for the window's neighbours (the result is the same bits;
  // tests compare the two).
  bool vector_kernels = true;
};

// Normals, curvature and surface covariances from the k nearest neighbours (nanoflann kd-tree).
// Normals are oriented towards `viewpoint` (the panorama centre). Throws on an empty cloud.
void prepare_surface(RegistrationCloud& cloud, const Eigen::Vector3d& viewpoint, const SurfaceOptions& options);

struct IcpOptions {
  IcpMethod method = IcpMethod::kGicpMeasured;
  double max_correspondence_m = 0.15;  // lambda_a (paper §6.1)
  int max_iterations = 50;             // paper §6.3; per coarse-to-fine level (below)
  double convergence_translation_m = 1e-6;
  double convergence_rotation_rad = 1e-7;
  // Also converged: the objective came back to its value of two steps before (within this
  // fraction) while the step was within coarse_tolerance_scale of the thresholds above (a pose
  // swaying between two correspondence sets).
  double convergence_relative_cost = 1e-9;
  int anisotropic_candidates = 8;  // Euclidean candidates for the Mahalanobis choice
  double curvature_scale = 0.05;   // "Curv": w = conf / (1 + (curvature / scale)^2)
  // Fitness: the fraction of source points whose correspondence lies within fitness_distance_m
  // at the end. A wrong local minimum in a room still finds walls within lambda_a for most
  // points, but few within a few centimetres. Below min_fitness the registration is reported as
  // failed (an Error), not returned as if it were fine; 0 disables the check.
  double fitness_distance_m = 0.03;
  double min_fitness = 0.0;
  // Coarse to fine: Gauss-Newton first on every (stride^L)-th source point, ..., every stride-th,
  // each level until its step is below coarse_tolerance_scale times the convergence thresholds,
  // then on all points until converged. Levels with fewer than coarse_min_points points are
  // skipped; 0 levels = all points from the start. The finest level alone decides convergence,
  // so the result is the full cloud's minimum; the coarse levels only make the early iterations,
  // when the pose is still far off, cheap.
  int coarse_levels = 2;
  int coarse_stride = 4;
  int coarse_min_points = 2000;
  double coarse_tolerance_scale = 100.0;
  int threads = 0;  // 0 = all cores

  void check() const;
};

// Wall-clock seconds of register_icp's phases (summed over iterations and levels).
struct IcpTimings {
  double setup_s = 0.0;           // the target's kd-tree, the combined covariances, the level subsets
  double correspondence_s = 0.0;  // nearest-neighbour search
  double linearise_s = 0.0;       // per-correspondence metric and the 6x6 normal equations
  double solve_s = 0.0;           // the 6x6 solve and the pose update
};

struct IcpResult {
  Rigid3d target_from_source = Rigid3d::Identity();
  int iterations = 0;  // Gauss-Newton steps over all levels
  bool converged = false;
  std::size_t correspondences = 0;   // at the last iteration
  double inlier_fraction = 0.0;      // correspondences / source points
  double fitness = 0.0;              // source points within fitness_distance_m / source points
  double rmse_m = 0.0;               // Euclidean RMSE of the correspondences at the end
  std::vector<double> cost_history;  // the objective per iteration of the finest level (its own metric)
  IcpTimings timings;
};

// Registers `source` onto `target` from `initial_target_from_source`. Both clouds must have
// gone through prepare_surface() for the methods that need normals or covariances; the
// measured/noise-model methods also need measurement_covariances. Throws Error on missing data,
// on no overlap, and when the final fitness is below options.min_fitness.
IcpResult register_icp(const RegistrationCloud& source, const RegistrationCloud& target,
                       const Rigid3d& initial_target_from_source, const IcpOptions& options);

}  // namespace panoscan
