#include "panoscan/recon/pose_graph.h"

#include <algorithm>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "panoscan/core/error.h"

namespace panoscan {

namespace {

// Relative-pose residual of one edge (see pose_graph.h), automatic derivatives.
struct RelativePoseError {
  RelativePoseError(const Rigid3d& to_from_from, double rotation_weight, double translation_weight)
      : measured_rotation(to_from_from.linear()),
        measured_translation(to_from_from.translation()),
        rotation_weight(rotation_weight),
        translation_weight(translation_weight) {}

  template <typename T>
  bool operator()(const T* from_q, const T* from_t, const T* to_q, const T* to_t, T* residual) const {
    using Quaternion = Eigen::Quaternion<T>;
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Quaternion> world_from_from_q(from_q), world_from_to_q(to_q);
    const Eigen::Map<const Vector3> world_from_from_t(from_t), world_from_to_t(to_t);
    // to_from_from = world_from_to^-1 * world_from_from.
    const Quaternion to_from_world_q = world_from_to_q.conjugate();
    const Quaternion relative_q = to_from_world_q * world_from_from_q;
    const Vector3 relative_t = to_from_world_q * (world_from_from_t - world_from_to_t);
    const Quaternion error_q = Quaternion(measured_rotation.template cast<T>()).conjugate() * relative_q;
    T error_angle_axis[3];
    const T error_wxyz[4] = {error_q.w(), error_q.x(), error_q.y(), error_q.z()};
    ceres::QuaternionToAngleAxis(error_wxyz, error_angle_axis);
    for (int k = 0; k < 3; ++k) {
      residual[k] = T(rotation_weight) * error_angle_axis[k];
      residual[3 + k] = T(translation_weight) * (relative_t[k] - T(measured_translation[k]));
    }
    return true;
  }

  static ceres::CostFunction* Create(const Rigid3d& to_from_from, double rotation_weight, double translation_weight) {
    return new ceres::AutoDiffCostFunction<RelativePoseError, 6, 4, 3, 4, 3>(
        new RelativePoseError(to_from_from, rotation_weight, translation_weight));
  }

  Eigen::Matrix3d measured_rotation;
  Eigen::Vector3d measured_translation;
  double rotation_weight, translation_weight;
};

}  // namespace

std::vector<EdgeDiscrepancy> edge_discrepancies(const std::vector<Rigid3d>& world_from_node,
                                                const std::vector<PoseGraphEdge>& edges) {
  std::vector<EdgeDiscrepancy> out;
  const int n = int(world_from_node.size());
  for (const PoseGraphEdge& e : edges) {
    if (e.from < 0 || e.from >= n || e.to < 0 || e.to >= n)
      throw make_error("", "pose graph edge", std::to_string(e.from) + " -> " + std::to_string(e.to) + " is invalid");
    const Rigid3d relative = world_from_node[e.to].inverse() * world_from_node[e.from];
    EdgeDiscrepancy d;
    d.rotation_deg = rad2deg(rotation_angle(e.to_from_from.linear().transpose() * relative.linear()));
    d.translation_m = (relative.translation() - e.to_from_from.translation()).norm();
    out.push_back(d);
  }
  return out;
}

EdgeDiscrepancy worst_edge_discrepancy(const std::vector<Rigid3d>& world_from_node,
                                       const std::vector<PoseGraphEdge>& edges) {
  EdgeDiscrepancy worst;
  for (const EdgeDiscrepancy& d : edge_discrepancies(world_from_node, edges)) {
    worst.rotation_deg = std::max(worst.rotation_deg, d.rotation_deg);
    worst.translation_m = std::max(worst.translation_m, d.translation_m);
  }
  return worst;
}

PoseGraphResult optimize_pose_graph(const std::vector<Rigid3d>& initial, const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphOptions& options) {
  const int n = int(initial.size());
  if (n == 0) throw make_error("", "pose graph", "has no nodes");
  if (options.fixed_node < 0 || options.fixed_node >= n) throw make_error("", "pose graph", "fixed node out of range");
  if (!(options.rotation_sigma_rad > 0 && options.translation_sigma_m > 0))
    throw make_error("", "pose graph", "edge sigmas must be positive");
  // Connectivity to the fixed node (union-find would do; n is tiny).
  std::vector<int> component(n);
  for (int i = 0; i < n; ++i) component[i] = i;
  auto root = [&](int i) {
    while (component[i] != i) i = component[i];
    return i;
  };
  for (const PoseGraphEdge& e : edges) {
    if (e.from < 0 || e.from >= n || e.to < 0 || e.to >= n || e.from == e.to)
      throw make_error("", "pose graph edge", std::to_string(e.from) + " -> " + std::to_string(e.to) + " is invalid");
    if (!e.to_from_from.matrix().allFinite()) throw make_error("", "pose graph edge", "non-finite measurement");
    component[root(e.from)] = root(e.to);
  }
  for (int i = 0; i < n; ++i) {
    if (!initial[i].matrix().allFinite())
      throw make_error("", "pose graph", "non-finite initial pose " + std::to_string(i));
    if (root(i) != root(options.fixed_node))
      throw make_error("", "pose graph", "node " + std::to_string(i) + " is not connected to the fixed node");
  }

  std::vector<Eigen::Quaterniond> rotations(n);
  std::vector<Eigen::Vector3d> translations(n);
  for (int i = 0; i < n; ++i) {
    rotations[i] = Eigen::Quaterniond(initial[i].linear()).normalized();
    translations[i] = initial[i].translation();
  }
  ceres::Problem problem;
  for (const PoseGraphEdge& e : edges)
    problem.AddResidualBlock(
        RelativePoseError::Create(e.to_from_from, 1.0 / options.rotation_sigma_rad, 1.0 / options.translation_sigma_m),
        nullptr, rotations[e.from].coeffs().data(), translations[e.from].data(), rotations[e.to].coeffs().data(),
        translations[e.to].data());
  for (int i = 0; i < n; ++i) {
    if (!problem.HasParameterBlock(rotations[i].coeffs().data())) continue;
    problem.SetManifold(rotations[i].coeffs().data(), new ceres::EigenQuaternionManifold);
  }
  if (problem.HasParameterBlock(rotations[options.fixed_node].coeffs().data())) {
    problem.SetParameterBlockConstant(rotations[options.fixed_node].coeffs().data());
    problem.SetParameterBlockConstant(translations[options.fixed_node].data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;  // tiny and sparse
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;  // a handful of nodes: threads cost more than they save
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  PoseGraphResult result;
  for (int i = 0; i < n; ++i) result.world_from_node.push_back(make_rigid(rotations[i], translations[i]));
  result.iterations = int(summary.iterations.size());
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  return result;
}

}  // namespace panoscan
