// Projective point-to-plane ICP between the depth grids of consecutive frames (depth_odometry.h).
#include "depth_odometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

namespace panoscan::depth_odometry {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// The grid's samples and, where their 3 x 3 window lies on one surface, their unit normals (facing
// the camera; zero where undefined).
struct SurfaceGrid {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;       // from the 3 x 3 window (the neighbours): the residual's
  std::vector<Eigen::Vector3d> wide_normals;  // from the 5 x 5 window where it lies on one surface, else the same
  std::vector<char> valid, has_normal;
};

// The largest depth difference from z at which a neighbour still lies on z's surface.
double same_surface_tolerance(double z, double c) { return std::max(0.1 * z, 6.0 * c * z * z); }

// Per sample, its row's run of 2 radius + 1 samples centred on it: whether all are valid, their z
// range, and the sums of P and of di P (di the offset from the centre). Set where the run lies
// inside the row.
struct RowRuns {
  std::vector<char> all_valid;
  std::vector<double> z_min, z_max;
  std::vector<Eigen::Vector3d> sum, moment;
};

RowRuns row_runs(const SurfaceGrid& s, int radius) {
  const std::size_t n = s.points.size();
  RowRuns runs;
  runs.all_valid.assign(n, 0);
  runs.z_min.assign(n, 0.0);
  runs.z_max.assign(n, 0.0);
  runs.sum.assign(n, Eigen::Vector3d::Zero());
  runs.moment.assign(n, Eigen::Vector3d::Zero());
  for (int j = 0; j < s.height; ++j)
    for (int i = radius; i + radius < s.width; ++i) {
      const std::size_t k = std::size_t(j) * s.width + i;
      bool all_valid = true;
      double z_min = s.points[k].z(), z_max = z_min;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
      for (int di = -radius; di <= radius && all_valid; ++di) {
        const std::size_t nb = std::size_t(std::ptrdiff_t(k) + di);
        all_valid = s.valid[nb] != 0;
        const Eigen::Vector3d& p = s.points[nb];
        z_min = std::min(z_min, p.z());
        z_max = std::max(z_max, p.z());
        sum += p;
        moment += double(di) * p;
      }
      if (!all_valid) continue;
      runs.all_valid[k] = 1;
      runs.z_min[k] = z_min;
      runs.z_max[k] = z_max;
      runs.sum[k] = sum;
      runs.moment[k] = moment;
    }
  return runs;
}

// Per sample, the unit normal of the least-squares plane through the (2 radius + 1)^2 samples around
// it, facing the camera; zero unless all of them are valid and lie on the centre's surface (within
// same_surface_tolerance of its depth, tested on the window's z range), and zero at the border. Its two
// gradients are the window's weighted differences (sum of d P / sum of d^2), summed as the rows'
// runs (RowRuns) combined down the columns: 2 (2 radius + 1) terms a sample instead of the square.
std::vector<Eigen::Vector3d> window_normals(const SurfaceGrid& s, int radius, double c) {
  std::vector<Eigen::Vector3d> normals(s.points.size(), Eigen::Vector3d::Zero());
  const RowRuns runs = row_runs(s, radius);
  for (int j = radius; j + radius < s.height; ++j)
    for (int i = radius; i + radius < s.width; ++i) {
      const std::size_t k = std::size_t(j) * s.width + i;
      if (!s.valid[k]) continue;
      const double z = s.points[k].z();
      bool all_valid = true;
      double z_min = z, z_max = z;
      Eigen::Vector3d along_i = Eigen::Vector3d::Zero(), along_j = Eigen::Vector3d::Zero();
      for (int dj = -radius; dj <= radius && all_valid; ++dj) {
        const std::size_t run = std::size_t(std::ptrdiff_t(k) + std::ptrdiff_t(dj) * s.width);
        all_valid = runs.all_valid[run] != 0;
        z_min = std::min(z_min, runs.z_min[run]);
        z_max = std::max(z_max, runs.z_max[run]);
        along_i += runs.moment[run];
        along_j += double(dj) * runs.sum[run];
      }
      const double tolerance = same_surface_tolerance(z, c);
      if (!all_valid || z_max - z > tolerance || z - z_min > tolerance) continue;
      Eigen::Vector3d normal = along_i.cross(along_j);
      const double norm = normal.norm();
      if (!(norm > 0.0)) continue;
      normal /= norm;
      normals[k] = normal.dot(s.points[k]) > 0.0 ? Eigen::Vector3d(-normal) : normal;
    }
  return normals;
}

SurfaceGrid surface_grid(const DepthGrid& grid, double c) {
  SurfaceGrid s;
  s.width = grid.depth.width;
  s.height = grid.depth.height;
  const std::size_t n = std::size_t(s.width) * s.height;
  s.points.assign(n, Eigen::Vector3d::Zero());
  s.valid.assign(n, 0);
  s.has_normal.assign(n, 0);
  for (int j = 0; j < s.height; ++j)
    for (int i = 0; i < s.width; ++i)
      if (grid.depth.at(i, j) > 0.0f) {
        s.points[std::size_t(j) * s.width + i] = grid.point(i, j);
        s.valid[std::size_t(j) * s.width + i] = 1;
      }
  s.normals = window_normals(s, 1, c);
  // Which directions a sample informs is decided with the wider window's normal (AlignOptions::
  // min_normal_alignment): across the disparity staircase's risers (2 cm at 2.5 m) the neighbours'
  // normals of a plain wall scatter by several degrees, the 5 x 5 window's by a fraction of that.
  // The residual keeps the 3 x 3 window's normal, which follows a surface up to one block from a
  // crease (the 5 x 5 one there too was worse on real scans).
  s.wide_normals = window_normals(s, 2, c);
  for (std::size_t k = 0; k < n; ++k) {
    s.has_normal[k] = !s.normals[k].isZero();
    if (!s.has_normal[k]) {
      s.wide_normals[k].setZero();
    } else if (s.wide_normals[k].isZero()) {
      s.wide_normals[k] = s.normals[k];
    }
  }
  return s;
}

// The 3-D pairing gate of iteration `iteration` before its per-sample floor: halves from max_distance_m.
double coarse_gate(const AlignOptions& o, int iteration) { return o.max_distance_m * std::pow(0.5, iteration); }

// The directions the residuals are resolved along: the eigenvectors of the rotation and of the
// translation block of the Hessian at the guess (columns), so that a plane's normal and the
// directions within it are among them; and which of them the samples do not observe.
struct Directions {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity(), translation = Eigen::Matrix3d::Identity();
  std::array<bool, 6> unobserved{};  // (rotations, translations): only the samples facing it inform it
};

// Per direction of Directions: the information of every sample and of the samples facing it.
struct FacingShare {
  std::array<double, 6> all{}, facing{};
};

struct Linearisation {
  Matrix6d hessian = Matrix6d::Zero();
  Vector6d gradient = Vector6d::Zero();
  int inliers = 0;
  double whitened_sq = 0.0;
};

// b's samples with what every linearisation needs of them, computed once per alignment.
struct SourceSamples {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> sigma_sq;  // (c z^2)^2
  std::vector<double> arm;       // |p|: a rotation's lever arm
};

SourceSamples source_samples(const DepthGrid& b, double c) {
  SourceSamples s;
  for (int j = 0; j < b.depth.height; ++j)
    for (int i = 0; i < b.depth.width; ++i)
      if (b.depth.at(i, j) > 0.0f) {
        const Eigen::Vector3d p = b.point(i, j);
        const double sigma = c * p.z() * p.z();
        s.points.push_back(p);
        s.sigma_sq.push_back(sigma * sigma);
        s.arm.push_back(p.norm());
      }
  return s;
}

// The whitened Jacobians' rows, kept between linearisations (one alignment runs a dozen).
struct JacobianRows {
  Eigen::Matrix<double, Eigen::Dynamic, 6> rows, weighted_rows;  // column k: the k-th component of every row
  Eigen::VectorXd residuals;
  // A FacingShare pass keeps every component and records here which directions each row faces (bit
  // i: direction i), so that the pass after it, at the same pose with the directions decided from its
  // shares, is these rows with the components dropped (normal_equations) instead of another pass.
  std::vector<std::uint8_t> facing;
};

// The normal equations of the first `count` stored rows: sum_k w_k J_k J_k^T and sum_k w_k J_k r_k as
// dot products of the stored columns (a 6 x 6 outer product per sample was a sixth of the time, a
// matrix product over the rows still a tenth), turned from the directions' basis to (omega, v).
void normal_equations(const JacobianRows& work, Eigen::Index count, const Directions* directions, Linearisation& lin) {
  Matrix6d hessian;
  Vector6d gradient;
  for (int i = 0; i < 6; ++i) {
    const auto weighted = work.weighted_rows.col(i).head(count);
    for (int k = i; k < 6; ++k) hessian(i, k) = hessian(k, i) = weighted.dot(work.rows.col(k).head(count));
    gradient[i] = weighted.dot(work.residuals.head(count));
  }
  if (directions) {
    Matrix6d to_tangent = Matrix6d::Zero();
    to_tangent.topLeftCorner<3, 3>() = directions->rotation;
    to_tangent.bottomRightCorner<3, 3>() = directions->translation;
    lin.hessian.noalias() = to_tangent * hessian * to_tangent.transpose();
    lin.gradient.noalias() = to_tangent * gradient;
  } else {
    lin.hessian = hessian;
    lin.gradient = gradient;
  }
}

// What linearise with `directions` returns at the pose and gate of the FacingShare pass that filled
// `work` (`share_pass`: its inliers and squared residuals): the stored rows, each component along an
// unobserved direction the row does not face set to zero, as linearise sets it. The same numbers as
// that pass, one projection of b's samples fewer.
Linearisation linearisation_after_share(JacobianRows& work, const Linearisation& share_pass,
                                        const Directions& directions) {
  Linearisation lin;
  lin.inliers = share_pass.inliers;
  lin.whitened_sq = share_pass.whitened_sq;
  const Eigen::Index count = share_pass.inliers;
  for (int i = 0; i < 6; ++i) {
    if (!directions.unobserved[std::size_t(i)]) continue;
    for (Eigen::Index row = 0; row < count; ++row)
      if (!(work.facing[std::size_t(row)] >> i & 1u)) work.rows(row, i) = work.weighted_rows(row, i) = 0.0;
  }
  normal_equations(work, count, &directions, lin);
  return lin;
}

// The normal equations of the point-to-plane residuals at a_from_b, pairs within the gate of
// iteration `iteration` (the gate halves from max_distance_m down to 4 sigma + one block's footprint).
// With `directions`, a sample informs an unobserved direction only where its surface faces it (the
// 5 x 5 window's normal: |n . e| >= min_normal_alignment for a translation e, |(p x n) . e| >= that
// times |p| for a rotation about e); its Jacobian's component along it is dropped otherwise (see
// AlignOptions::min_normal_alignment for why). `share`, if given, sums each direction's information.
//
// The Jacobian is formed in the directions' basis, where the dropping happens, and the sums are
// turned back to (omega, v) once: with b's normal n_b = R^T n, d r / d omega = p x n_b = R^T (R p x n),
// so its components along the rotation directions D_r are (D_r^T R^T) (R p x n), and those of
// d r / d v = n_b along D_t are (D_t^T R^T) n; H = T H' T^T and g = T g' with T = diag(D_r, D_t).
Linearisation linearise(const SurfaceGrid& a, const PinholeIntrinsics& grid_a, const SourceSamples& b,
                        const Rigid3d& a_from_b, int iteration, const AlignOptions& o, JacobianRows& work,
                        const Directions* directions = nullptr, FacingShare* share = nullptr) {
  Linearisation lin;
  const Directions identity;
  const Directions& basis = directions ? *directions : identity;
  const Eigen::Matrix3d rotation = a_from_b.linear();
  const Eigen::Vector3d translation = a_from_b.translation();
  const Eigen::Matrix3d about_of_cross = basis.rotation.transpose() * rotation.transpose();
  const Eigen::Matrix3d along_of_normal = basis.translation.transpose() * rotation.transpose();
  const double c = o.depth_noise_coefficient;
  const double gate_before_floor = coarse_gate(o, iteration);
  const std::size_t n = b.points.size();
  if (std::size_t(work.rows.rows()) < n) {
    work.rows.resize(Eigen::Index(n), 6);
    work.weighted_rows.resize(Eigen::Index(n), 6);
    work.residuals.resize(Eigen::Index(n));
  }
  if (share && work.facing.size() < n) work.facing.resize(n);
  Eigen::Index count = 0;
  for (std::size_t s = 0; s < n; ++s) {
    const Eigen::Vector3d& p = b.points[s];
    const Eigen::Vector3d rotated = rotation * p;
    const Eigen::Vector3d moved = rotated + translation;
    if (!(moved.z() > 0.0)) continue;
    const double inverse_z = 1.0 / moved.z();
    // Rounded to the nearest block (half up) without libm's lround, which was a tenth of the time.
    const double column = grid_a.fx * moved.x() * inverse_z + grid_a.cx;
    const double row = grid_a.fy * moved.y() * inverse_z + grid_a.cy;
    if (!(column > -0.5 && row > -0.5 && column < a.width - 0.5 && row < a.height - 0.5)) continue;
    const int u = int(column + 0.5), v = int(row + 0.5);
    const std::size_t k = std::size_t(v) * a.width + u;
    if (!a.has_normal[k]) continue;
    const Eigen::Vector3d& q = a.points[k];
    const Eigen::Vector3d& normal = a.normals[k];
    const double sigma_q = c * q.z() * q.z();
    const double sigma = std::sqrt(sigma_q * sigma_q + b.sigma_sq[s]);
    const double footprint = q.z() / grid_a.fx;
    const double gate = std::max(gate_before_floor, 4.0 * sigma + footprint);
    const Eigen::Vector3d diff = moved - q;
    if (diff.squaredNorm() > gate * gate) continue;
    const double inverse_sigma = 1.0 / sigma;
    const double r = normal.dot(diff) * inverse_sigma;
    const double weight = std::abs(r) <= o.huber_delta ? 1.0 : o.huber_delta / std::abs(r);
    Eigen::Vector3d about = about_of_cross * rotated.cross(normal);
    Eigen::Vector3d along = along_of_normal * normal;
    if (directions) {
      const Eigen::Vector3d& wide = a.wide_normals[k];
      const Eigen::Vector3d wide_about = about_of_cross * rotated.cross(wide);
      const Eigen::Vector3d wide_along = along_of_normal * wide;
      const double arm = b.arm[s];
      std::uint8_t facing = 0;
      for (int i = 0; i < 3; ++i) {
        const bool faces_rotation = std::abs(wide_about[i]) >= o.min_normal_alignment * arm;
        const bool faces_translation = std::abs(wide_along[i]) >= o.min_normal_alignment;
        if (share) {
          const double rotation_information = weight * about[i] * about[i] / (sigma * sigma);
          const double translation_information = weight * along[i] * along[i] / (sigma * sigma);
          share->all[std::size_t(i)] += rotation_information;
          share->all[std::size_t(3 + i)] += translation_information;
          if (faces_rotation) share->facing[std::size_t(i)] += rotation_information;
          if (faces_translation) share->facing[std::size_t(3 + i)] += translation_information;
          facing |= std::uint8_t((faces_rotation ? 1u : 0u) << i | (faces_translation ? 1u : 0u) << (3 + i));
          continue;  // every component kept; linearisation_after_share drops them
        }
        if (directions->unobserved[std::size_t(i)] && !faces_rotation) about[i] = 0.0;
        if (directions->unobserved[std::size_t(3 + i)] && !faces_translation) along[i] = 0.0;
      }
      if (share) work.facing[std::size_t(count)] = facing;
    }
    for (int i = 0; i < 3; ++i) {
      work.rows(count, i) = about[i] * inverse_sigma;
      work.rows(count, 3 + i) = along[i] * inverse_sigma;
    }
    for (int i = 0; i < 6; ++i) work.weighted_rows(count, i) = weight * work.rows(count, i);
    work.residuals[count] = r;
    lin.whitened_sq += r * r;
    ++count;
  }
  lin.inliers = int(count);
  normal_equations(work, count, directions, lin);
  return lin;
}

}  // namespace

AlignResult align_depth_grids(const DepthGrid& a, const DepthGrid& b, const Rigid3d& a_from_b_guess,
                              const AlignOptions& o, const TurnAxis* turn) {
  AlignResult result;
  if (a.empty() || b.empty()) {
    result.reason = "no depth grid";
    return result;
  }
  const SurfaceGrid target = surface_grid(a, o.depth_noise_coefficient);
  const SourceSamples source = source_samples(b, o.depth_noise_coefficient);
  result.samples = int(source.points.size());
  JacobianRows work;

  Rigid3d a_from_b = a_from_b_guess;
  // The directions the samples are resolved along and which of them they do not observe: a
  // direction most of whose information comes from samples not facing it is unobserved. Decided at
  // the guess with the first (widest) gate, again where the turn (below) has moved b, and at the
  // solution for the information.
  Directions directions;
  const Directions* resolved = nullptr;
  // The linearisation at the current pose and gate, where one was made before the pose moved: each
  // resolve_directions ends with the rows of the pass that follows it (linearisation_after_share), and
  // a skipped turn phase leaves its own. Bit for bit what another pass would give.
  std::optional<Linearisation> ready;
  auto resolve_directions = [&](int gate_level) {
    if (!(o.min_normal_alignment > 0.0)) return;
    const Linearisation first = linearise(target, a.intrinsics, source, a_from_b, gate_level, o, work);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotation(first.hessian.topLeftCorner<3, 3>());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(first.hessian.bottomRightCorner<3, 3>());
    directions.rotation = rotation.eigenvectors();
    directions.translation = translation.eigenvectors();
    FacingShare share;
    const Linearisation share_pass =
        linearise(target, a.intrinsics, source, a_from_b, gate_level, o, work, &directions, &share);
    for (std::size_t i = 0; i < 6; ++i)
      directions.unobserved[i] = !(share.facing[i] >= o.min_facing_share * share.all[i]);
    resolved = &directions;
    ready = linearisation_after_share(work, share_pass, directions);
  };
  resolve_directions(0);

  // With `turn` (the rotator), two phases come first. A guess several degrees off in the turn (a
  // rotator step faster than the ones around it) puts b's samples decimetres from their partners;
  // a 6-DoF step from there traded the missing turn for a slide, the gate shrank on schedule, and
  // the estimate settled in the wrong basin (rotation right, 17-160 mm off in translation on a
  // generated office; recon/tracking/README.md, "Depth odometry").
  //  1. the turn about the axis alone: delta = theta (d, p x d) turns b's samples by theta about the
  //     line through p along d (first order);
  //  2. turns about p in any direction, delta = (omega, p x omega), which takes up the wobble's tilt;
  //  3. all six degrees of freedom, with the gate shrinking to its floor.
  // A phase ends when a step moves a typical sample by less than a tenth of the first gate, or after
  // max_turn_iterations; a turn that leaves the guess by more than max_step_deg has lost its way,
  // and phase 3 starts from the guess.
  enum class Phase { kTurnAboutAxis, kTurnAboutPivot, kFree };
  Phase phase = turn != nullptr && o.max_turn_iterations > 0 ? Phase::kTurnAboutAxis : Phase::kFree;
  Vector6d axis_turn = Vector6d::Zero();
  Eigen::Matrix<double, 6, 3> pivot_turns = Eigen::Matrix<double, 6, 3>::Zero();
  if (turn) {
    axis_turn.head<3>() = turn->direction.normalized();
    axis_turn.tail<3>() = turn->point.cross(axis_turn.head<3>());
    const Eigen::Vector3d& p = turn->point;
    pivot_turns.topRows<3>().setIdentity();
    pivot_turns.bottomRows<3>() << 0.0, -p.z(), p.y(), p.z(), 0.0, -p.x(), -p.y(), p.x(), 0.0;
  }
  // The samples' mean distance from b's centre: how far a turn moves a typical sample.
  double mean_arm = 0.0;
  for (const double arm : source.arm) mean_arm += arm;
  if (!source.arm.empty()) mean_arm /= double(source.arm.size());
  auto next_phase = [&] {
    phase = phase == Phase::kTurnAboutAxis ? Phase::kTurnAboutPivot : Phase::kFree;
    if (phase == Phase::kFree) resolve_directions(0);  // b's samples may meet other surfaces of a now
  };

  int iteration = 0, turn_iterations = 0, phase_iterations = 0, gate_level = 0;
  bool converged = false;
  std::vector<Rigid3d> history;  // the estimate after each step of phase 3
  while (iteration - turn_iterations < o.max_iterations) {
    const Linearisation lin =
        ready ? *ready : linearise(target, a.intrinsics, source, a_from_b, gate_level, o, work, resolved);
    ready.reset();
    if (lin.inliers < 6) break;
    Vector6d delta;
    if (phase == Phase::kTurnAboutAxis) {
      // One-dimensional Gauss-Newton; a turn the samples do not observe (a floor alone) is skipped.
      const double curvature = axis_turn.dot(lin.hessian * axis_turn);
      if (!(curvature > 1e-9 * lin.hessian.trace())) {
        phase_iterations = 0;
        next_phase();  // to the turns about the pivot, at the same pose
        ready = lin;
        continue;
      }
      delta = -(axis_turn.dot(lin.gradient) / curvature) * axis_turn;
    } else if (phase == Phase::kTurnAboutPivot) {
      // Gauss-Newton over the turns the samples observe: the pseudo-inverse drops a turn with a
      // vanishing share of the information (two vertical walls say little of one tilt), where a
      // damped solve stepped by thousands of degrees.
      const Eigen::Matrix3d reduced = pivot_turns.transpose() * lin.hessian * pivot_turns;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (reduced + reduced.transpose()));
      const Eigen::Vector3d projected = eigen.eigenvectors().transpose() * (pivot_turns.transpose() * lin.gradient);
      Eigen::Vector3d omega = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k)
        if (eigen.eigenvalues()(k) > 1e-6 * eigen.eigenvalues()(2))
          omega -= eigen.eigenvectors().col(k) * (projected(k) / eigen.eigenvalues()(k));
      delta = pivot_turns * omega;
    } else {
      // Gauss-Newton with a whisper of damping: a plain wall leaves directions without information.
      Matrix6d damped = lin.hessian;
      damped.diagonal().array() += 1e-9 * lin.hessian.trace() / 6.0 + 1e-12;
      delta = -damped.ldlt().solve(lin.gradient);
    }
    if (!delta.allFinite()) break;
    Rigid3d step = Rigid3d::Identity();
    step.linear() = so3_exp(delta.head<3>());
    step.translation() = delta.tail<3>();
    a_from_b = a_from_b * step;
    ++iteration;
    if (phase != Phase::kFree) {
      ++turn_iterations;
      ++phase_iterations;
      if (rad2deg(rotation_angle((a_from_b_guess.inverse() * a_from_b).linear())) > o.max_step_deg) {
        a_from_b = a_from_b_guess;
        phase = Phase::kTurnAboutPivot;  // next_phase() moves on to phase 3
      } else if (phase_iterations < o.max_turn_iterations &&
                 delta.head<3>().norm() * mean_arm > 0.1 * o.max_distance_m) {
        continue;
      }
      phase_iterations = 0;
      next_phase();
      continue;
    }
    history.push_back(a_from_b);
    // Converged once the gate has shrunk to its floor (below 1 mm the per-sample floor of 4 sigma +
    // one block's footprint rules) and the step is a small fraction of the estimate's own standard
    // deviation: its length in the information metric, sqrt(delta^T H delta), is in those units.
    const bool gate_at_floor = coarse_gate(o, gate_level) <= 1e-3;
    if (gate_at_floor && delta.dot(lin.hessian * delta) < o.converged_step_sigma * o.converged_step_sigma) {
      converged = true;
      break;
    }
    ++gate_level;
  }
  result.iterations = iteration;
  // The information at the solution, with the final (tightest) gate, over the directions the samples
  // observe there. Decided at the guess only, a guess several degrees off let b's samples of a plain
  // wall meet a table in a, and the information claimed 1 mm along the wall's slides.
  ready.reset();
  resolve_directions(o.max_iterations + 64);
  const Linearisation final_lin =
      ready ? *ready : linearise(target, a.intrinsics, source, a_from_b, o.max_iterations + 64, o, work, resolved);
  result.inliers = final_lin.inliers;
  result.a_from_b = a_from_b;
  result.information = o.information_scale * final_lin.hessian;
  result.whitened_rms = final_lin.inliers > 0 ? std::sqrt(final_lin.whitened_sq / final_lin.inliers) : 0.0;
  result.converged = converged;
  // Projective association re-pairs samples as the pose moves, and some pairs circle in a limit
  // cycle above converged_step_sigma instead of settling: judged by how far the last five steps took
  // the estimate in all (in its own standard deviations), a cycle goes nowhere, a drift does.
  constexpr std::size_t kSettleSteps = 5;
  if (!converged && history.size() > kSettleSteps) {
    const Rigid3d lately = history[history.size() - 1 - kSettleSteps].inverse() * a_from_b;
    Vector6d moved;
    moved.head<3>() = so3_log(lately.linear());
    moved.tail<3>() = lately.translation();
    result.unsettled_sigma = std::sqrt(std::max(0.0, moved.dot(final_lin.hessian * moved)));
  } else if (!converged) {
    result.unsettled_sigma = std::numeric_limits<double>::infinity();
  }

  const Rigid3d moved = a_from_b_guess.inverse() * a_from_b;
  if (!converged && !(result.unsettled_sigma <= o.max_unsettled_sigma)) {
    result.reason = "did not converge";
  } else if (result.inliers < o.min_inliers || result.inliers < o.min_overlap * result.samples) {
    result.reason = "too little overlap";
  } else if (rad2deg(rotation_angle(moved.linear())) > o.max_step_deg || moved.translation().norm() > o.max_step_m) {
    result.reason = "moved too far from the guess";
  } else if (!result.a_from_b.matrix().allFinite() || !result.information.allFinite()) {
    result.reason = "not finite";
  } else {
    result.ok = true;
  }
  return result;
}

Eigen::Matrix<double, 6, 6> information_sqrt(const Eigen::Matrix<double, 6, 6>& information) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (information + information.transpose()));
  const Vector6d root = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return root.asDiagonal() * eigen.eigenvectors().transpose();
}

}  // namespace panoscan::depth_odometry
