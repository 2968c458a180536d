// Internal to panoscan_recon_tracking (and its tests): depth odometry between consecutive frames of
// one camera, the measurement of the depth factor (track.depth_odometry, on by default; beyond the paper).
//
// Why: the paper's graph carries a frame that sees only a plain wall or ceiling by Eq. 2-3 alone
// (the rotator model). The depth of such a frame still constrains its pose: a wall fixes the
// rotation about every axis in its plane (the turn about the vertical axis among them) and the
// translation along its normal. Point-to-plane ICP between consecutive frames measures exactly
// those directions and, through its Gauss-Newton Hessian, says which directions it does not
// measure (the slide along the wall, the turn about its normal get no information).
//
// The alignment: projective point-to-plane ICP (as in KinectFusion) on the block-mean grids of
// depth_grid.h. Frame b's samples are moved by the current a_from_b, projected into a's grid, and
// paired with the sample there and its normal (central differences over the neighbouring blocks).
// The residual n . (X p - q) is whitened by the depth noise of both samples (sigma_z = c z^2 each)
// and Huber-weighted; a pair is dropped beyond a 3-D distance gate that shrinks from max_distance_m
// to a few sigma plus one block's footprint. Gauss-Newton steps X <- X exp(delta), delta = (omega,
// v) applied in b's frame, until the gate has reached its floor and a step moves the estimate by less
// than converged_step_sigma of its own standard deviation (sqrt(delta^T H delta)). Projective
// association re-pairs samples as the pose moves, so the steps do not fall to zero: they settle into
// a limit cycle of a few hundredths of a sigma, and a fixed tiny threshold (1e-7) ran most pairs to
// max_iterations for nothing (recon/tracking/README.md, "Depth odometry", Cost). A pair still
// moving after max_iterations is not used: unless its last five steps went nowhere (a limit cycle
// above the threshold, max_unsettled_sigma), it is drifting along what it barely observes.
// On a rotator (TurnAxis) the 6-DoF steps are preceded by turns about the rig's axis, then about a
// point on it: the guess's error there is mostly a turn, and from a guess several degrees off a
// 6-DoF start traded the turn for a slide and settled centimetres off (align_depth_grids).
//
// Which directions a sample informs: a wall's samples all but "measured" the slide along it
// through their normals' scatter (AlignOptions::min_normal_alignment). The rotations and translations
// are resolved along the eigenvectors of the Hessian's two 3 x 3 blocks at the guess (for a wall: its
// normal and two directions within it). A direction is unobserved when most of its information comes
// from samples whose normal (over a 5 x 5-sample window) does not lean towards it
// (min_facing_share); along an unobserved direction only the samples facing it keep their Jacobian's
// component, so Gauss-Newton and the information leave it where the guess put it (none facing: no
// information at all). An observed direction keeps every sample.
//
// Which directions are unobserved is decided at the guess, again after the turns, and at the
// solution for the information (from a guess several degrees off, b's samples of a plain wall met a
// table in a at the guess, and the information claimed 1 mm along the wall's slides).
//
// The information: H = sum_k w_k J_k^T J_k / sigma_k^2 at the solution, in the (omega, v) order
// of a right perturbation, times information_scale. Summing over every block treats their errors
// as independent, which the disparity quantisation (a staircase correlated along the surface)
// breaks: information_scale < 1 accounts for that (its default: recon/tracking/README.md,
// "Depth odometry").
#pragma once

#include <string>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"
#include "panoscan/recon/depth_grid.h"

namespace panoscan::depth_odometry {

struct AlignOptions {
  double depth_noise_coefficient = 9.49e-4;  // sigma_z = c z^2 per sample (ARCHITECTURE.md §4.1)
  double max_distance_m = 0.10;              // the first iterations' 3-D pairing gate
  int max_iterations = 30;                   // of the 6-DoF phase
  int max_turn_iterations = 10;              // of each turn phase before it (with a TurnAxis; 0: none)
  // A pair that has not converged by max_iterations is used only when its last five steps moved it
  // by at most this many of its standard deviations (a limit cycle of the projective association, not
  // a drift; align_depth_grids).
  double max_unsettled_sigma = 1.0;
  // Converged when a step moves the estimate by less than this many of its standard deviations.
  double converged_step_sigma = 0.1;
  double huber_delta = 2.796;       // on the whitened residual
  double min_overlap = 0.25;        // inliers / b's valid samples, below which the pair is not used
  int min_inliers = 50;             // and at least this many
  double max_step_deg = 5.0;        // the solution may move this far from the guess (a larger jump: lost)
  double max_step_m = 0.20;
  double information_scale = 1.0;   // multiplies the Hessian (see above)
  // A sample faces a direction when its normal (the 5 x 5 window's) leans at least this much towards
  // it: |n . e| for a translation e, |(p x n) . e| / |p| for a rotation about e (0 = no direction is
  // ever unobserved). The neighbours' normals of a flat wall scatter by several degrees across the
  // disparity staircase, and through that scatter every sample of a plain wall "measured" the slide
  // along it: thousands of them summed to a claimed 0.3-0.6 mm standard deviation for a slide
  // nothing observes, and the ICP, free to drift along it, followed the staircase 6-7 cm (a
  // generated living room; recon/tracking/README.md, "Depth odometry"). 0.2 (11.5 deg) lies well
  // above the wider window's scatter and well below the alignment of a surface that faces the
  // direction.
  double min_normal_alignment = 0.2;
  // A direction is unobserved when the samples facing it give less than this share of its
  // information. Unobserved directions (a wall's slides and the turn about its normal) got 0.00-0.09,
  // observed ones 0.47-1.00 (rotations, whose lever arms are shorter) and 0.93-1.00 (translations).
  // Applying the facing rule to every direction instead also dropped the central columns' real
  // information on the turn about the vertical, and Table 2's single camera lost 25-30%.
  double min_facing_share = 0.5;
};

struct AlignResult {
  bool ok = false;
  std::string reason;  // why not ok
  Rigid3d a_from_b = Rigid3d::Identity();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();  // (omega, v), right perturbation
  int samples = 0, inliers = 0, iterations = 0;
  double whitened_rms = 0.0;  // RMS of the whitened residuals of the inliers
  bool converged = false;     // a step fell below converged_step_sigma with the gate at its floor
  double unsettled_sigma = 0.0;  // not converged: how far the last five steps moved it (its own sigmas)
};

// A line in b's frame about which the guess's error is a turn: the rig's axis on a rotator.
struct TurnAxis {
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), direction = Eigen::Vector3d::UnitY();
};

// Aligns grid b to grid a (both of one camera: same intrinsics and block), starting from
// a_from_b_guess: with `turn`, first turning b about that axis until the turn settles; then in all six
// degrees of freedom.
AlignResult align_depth_grids(const DepthGrid& a, const DepthGrid& b, const Rigid3d& a_from_b_guess,
                              const AlignOptions& options, const TurnAxis* turn = nullptr);

// The rows S with S^T S = information (eigen-decomposition; negative eigenvalues from rounding are
// clipped to 0): the factor's residual is S (rotation vector, translation) of the error transform.
Eigen::Matrix<double, 6, 6> information_sqrt(const Eigen::Matrix<double, 6, 6>& information);

}  // namespace panoscan::depth_odometry
