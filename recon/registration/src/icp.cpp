// The ICP family of Table 4 as one Gauss-Newton loop; methods differ in the per-correspondence
// metric M_i and in the choice of correspondence (see registration.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

#include <Eigen/Cholesky>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/recon/registration.h"

namespace panoscan {

const char* to_string(IcpMethod method) {
  switch (method) {
    case IcpMethod::kPointToPoint: return "p2point";
    case IcpMethod::kPointToPlane: return "p2plane";
    case IcpMethod::kPointToPlaneCurvature: return "p2plane-curv";
    case IcpMethod::kGicp: return "gicp";
    case IcpMethod::kAnisotropic: return "anisotropic";
    case IcpMethod::kGicpNoiseModel: return "gicp-def";
    case IcpMethod::kGicpMeasured: return "gicp-ours";
  }
  return "?";
}

IcpMethod icp_method_from_string(const std::string& name) {
  for (IcpMethod m : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane, IcpMethod::kPointToPlaneCurvature,
                      IcpMethod::kGicp, IcpMethod::kAnisotropic, IcpMethod::kGicpNoiseModel, IcpMethod::kGicpMeasured})
    if (name == to_string(m)) return m;
  throw make_error("", "registration method",
                   "unknown '" + name + "' (p2point, p2plane, p2plane-curv, gicp, anisotropic, gicp-def, gicp-ours)");
}

void IcpOptions::check() const {
  if (!(max_correspondence_m > 0)) throw make_error("", "registration.max_correspondence_m", "must be positive");
  if (max_iterations < 1) throw make_error("", "registration.max_iterations", "must be at least 1");
  if (anisotropic_candidates < 1) throw make_error("", "registration.anisotropic_candidates", "must be at least 1");
  if (!(curvature_scale > 0)) throw make_error("", "registration.curvature_scale", "must be positive");
  if (!(fitness_distance_m > 0)) throw make_error("", "registration.fitness_distance_m", "must be positive");
  if (!(min_fitness >= 0 && min_fitness <= 1)) throw make_error("", "registration.min_fitness", "must be in [0, 1]");
  if (coarse_levels < 0) throw make_error("", "registration.coarse_levels", "must be at least 0");
  if (coarse_stride < 2) throw make_error("", "registration.coarse_stride", "must be at least 2");
  if (coarse_min_points < 6) throw make_error("", "registration.coarse_min_points", "must be at least 6");
  if (!(convergence_relative_cost >= 0)) throw make_error("", "registration.convergence_relative_cost", "must be >= 0");
  if (!(coarse_tolerance_scale >= 1)) throw make_error("", "registration.coarse_tolerance_scale", "must be at least 1");
}

namespace {

constexpr std::size_t kBlock = 1024;  // fixed reduction blocks: results independent of threads

bool uses_normals(IcpMethod m) { return m == IcpMethod::kPointToPlane || m == IcpMethod::kPointToPlaneCurvature; }
bool uses_surface_covariance(IcpMethod m) {
  return m == IcpMethod::kGicp || m == IcpMethod::kAnisotropic || m == IcpMethod::kGicpNoiseModel ||
         m == IcpMethod::kGicpMeasured;
}
bool uses_measurement_covariance(IcpMethod m) {
  return m == IcpMethod::kGicpNoiseModel || m == IcpMethod::kGicpMeasured;
}

void check_cloud(const RegistrationCloud& cloud, const char* role, IcpMethod method) {
  const std::size_t n = cloud.points.size();
  if (n == 0) throw make_error("", std::string(role) + " cloud", "is empty");
  if ((uses_normals(method) || uses_surface_covariance(method)) &&
      (cloud.normals.size() != n || cloud.surface_covariances.size() != n || cloud.curvature.size() != n))
    throw make_error("", std::string(role) + " cloud", std::string("needs prepare_surface() for ") + to_string(method));
  if (uses_measurement_covariance(method) && cloud.measurement_covariances.size() != n)
    throw make_error("", std::string(role) + " cloud",
                     std::string("needs one measurement covariance per point for ") + to_string(method));
  if (!cloud.confidence.empty() && cloud.confidence.size() != n)
    throw make_error("", std::string(role) + " cloud", "confidence must be empty or one per point");
}

struct Partial {
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
  double cost = 0.0;
  double squared_error = 0.0;
  std::size_t count = 0;
  std::size_t close = 0;  // correspondences within the fitness distance
};

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Combined covariance of each point for the GICP family (Eq. 8/9): the surface part plus, for the
// noise-model methods, the measurement part. Summed once per registration instead of once per
// correspondence and iteration (half the memory traffic of the inner loop).
std::vector<Eigen::Matrix3d> combined_covariances(const RegistrationCloud& cloud, IcpMethod method) {
  if (!uses_surface_covariance(method)) return {};
  std::vector<Eigen::Matrix3d> combined = cloud.surface_covariances;
  if (uses_measurement_covariance(method))
    for (std::size_t i = 0; i < combined.size(); ++i) combined[i] += cloud.measurement_covariances[i];
  return combined;
}

class Problem {
 public:
  Problem(const RegistrationCloud& source, const RegistrationCloud& target, const IcpOptions& options)
      : source_(source),
        target_(target),
        options_(options),
        correspondences_(source.points.size(), -1),
        searched_at_(source.points.size()),
        clear_(source.points.size(), 0.0) {
    // Independent, and at 524k points tens of milliseconds each (the tree's build is serial).
    tbb::parallel_invoke([&] { tree_ = std::make_unique<PointKdTree>(target.points); },
                         [&] { source_covariances_ = combined_covariances(source, options.method); },
                         [&] { target_covariances_ = combined_covariances(target, options.method); });
    if (options.method == IcpMethod::kPointToPlaneCurvature && !target.confidence.empty()) {
      // Confidence relative to the median count, saturating: a pixel seen twice as often as
      // the typical one is not twice as trustworthy.
      std::vector<float> sorted = target.confidence;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      median_confidence_ = std::max(1.f, sorted[sorted.size() / 2]);
    }
  }

  // Metric M of the correspondence (source i placed at `rotation`, target j).
  Eigen::Matrix3d metric(std::size_t i, std::size_t j, const Eigen::Matrix3d& rotation) const {
    switch (options_.method) {
      case IcpMethod::kPointToPoint: return Eigen::Matrix3d::Identity();
      case IcpMethod::kPointToPlane:
      case IcpMethod::kPointToPlaneCurvature: {
        const Eigen::Vector3d& n = target_.normals[j];
        double weight = 1.0;
        if (options_.method == IcpMethod::kPointToPlaneCurvature) {
          const double c = target_.curvature[j] / options_.curvature_scale;
          weight = 1.0 / (1.0 + c * c);
          if (!target_.confidence.empty()) weight *= std::min(1.0, double(target_.confidence[j]) / median_confidence_);
        }
        // A tiny isotropic part keeps the system regular on degenerate (single-plane) overlaps.
        return weight * (n * n.transpose() + 1e-6 * Eigen::Matrix3d::Identity());
      }
      default:
        // Eq. 8/9: combined covariance R C_s R^T + C_t, inverted.
        return (rotation * source_covariances_[i] * rotation.transpose() + target_covariances_[j]).inverse();
    }
  }

  // Finds the correspondence of every source point in `active` placed by target_from_source: its
  // nearest target point within lambda_a, exactly.
  // - The search is bounded by lambda_a and, when the point had a correspondence before, by twice
  //   its distance to that one: the previous match bounds the nearest, so most of the tree is pruned.
  // - It returns the two nearest, and remembers where the point was searched from (s) and how far the
  //   second one was (c; lambda_a or the bound when there was none). Every other target point is then
  //   at least c from s, so at least c - |q - s| from the point's new place q.
  // - Once the pose settles, the point moves by micrometres between iterations while c exceeds the
  //   nearest distance by millimetres: if the remembered match is closer to q than c - |q - s| (and
  //   than lambda_a), it is still the strict nearest and the search is skipped. The result is the
  //   search's own (ties aside, which the search also breaks arbitrarily).
  void correspond(const Rigid3d& target_from_source, const std::vector<std::uint32_t>& active) {
    const Eigen::Matrix3d rotation = target_from_source.linear();
    const double max_d = options_.max_correspondence_m;
    const std::size_t n = active.size();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kBlock), [&](const tbb::blocked_range<std::size_t>& r) {
      std::uint32_t candidates[32];
      double squared[32];
      for (std::size_t a = r.begin(); a != r.end(); ++a) {
        const std::uint32_t i = active[a];
        const Eigen::Vector3d q = target_from_source * source_.points[i];
        if (options_.method != IcpMethod::kAnisotropic) {
          double bound = max_d;
          if (correspondences_[i] >= 0) {
            const double to_match = (target_.points[std::size_t(correspondences_[i])] - q).norm();
            // Relative and absolute margins for the rounding of the three distances.
            const double others_at_least = (clear_[i] - (q - searched_at_[i]).norm()) * (1 - 1e-9) - 1e-12;
            if (to_match < others_at_least && to_match < max_d) continue;
            bound = std::min(bound, 2 * to_match * (1 + 1e-9) + 1e-12);
          }
          std::uint32_t nearest[2];
          double squared_distances[2];
          const std::size_t found = tree_->knn_within(q, 2, bound, nearest, squared_distances);
          if (found == 0) {
            correspondences_[i] = -1;
            continue;
          }
          correspondences_[i] = long(nearest[0]);
          searched_at_[i] = q;
          clear_[i] = found == 2 ? std::sqrt(squared_distances[1]) : bound;
          continue;
        }
        // Anisotropic ICP: the Mahalanobis-nearest among the Euclidean candidates.
        const std::size_t k = std::min<std::size_t>(options_.anisotropic_candidates, 32);
        const std::size_t found = tree_->knn(q, k, candidates, squared);
        long best = -1;
        double best_cost = 0;
        for (std::size_t c = 0; c < found; ++c) {
          if (squared[c] > max_d * max_d) break;
          const Eigen::Vector3d d = target_.points[candidates[c]] - q;
          const double cost = d.dot(metric(i, candidates[c], rotation) * d);
          if (best < 0 || cost < best_cost) {
            best = candidates[c];
            best_cost = cost;
          }
        }
        correspondences_[i] = best;
      }
    });
  }

  // Gauss-Newton normal equations of the current correspondences of the `active` source points.
  Partial linearise(const Rigid3d& target_from_source, const std::vector<std::uint32_t>& active) const {
    const std::size_t n = active.size();
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    std::vector<Partial> partials(blocks);
    const Eigen::Matrix3d rotation = target_from_source.linear();
    const double fitness2 = options_.fitness_distance_m * options_.fitness_distance_m;
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      Partial& partial = partials[b];
      const std::size_t end = std::min(n, (b + 1) * kBlock);
      for (std::size_t a = b * kBlock; a < end; ++a) {
        const std::uint32_t i = active[a];
        const long j = correspondences_[i];
        if (j < 0) continue;
        const Eigen::Vector3d q = target_from_source * source_.points[i];
        const Eigen::Matrix3d m = metric(i, std::size_t(j), rotation);
        const Eigen::Vector3d d = target_.points[std::size_t(j)] - q;
        // d(xi) = b - exp(xi) q ~ d + J xi, J = [ [q]x  -I ] (left perturbation, xi = (omega, v)).
        // J^T M J and J^T M d written out by blocks ([q]x^T = -[q]x, M symmetric), a third of the
        // general 6x3 products' work; the lower-left block is filled once from the upper-right.
        const Eigen::Matrix3d q_cross = skew(q);
        const Eigen::Matrix3d m_q = m * q_cross;  // M [q]x
        const Eigen::Vector3d m_d = m * d;
        partial.hessian.topLeftCorner<3, 3>().noalias() -= q_cross * m_q;
        partial.hessian.topRightCorner<3, 3>() -= m_q.transpose();
        partial.hessian.bottomRightCorner<3, 3>() += m;
        partial.gradient.head<3>() += m_d.cross(q);
        partial.gradient.tail<3>() -= m_d;
        partial.cost += d.dot(m * d);
        partial.squared_error += d.squaredNorm();
        ++partial.count;
        partial.close += d.squaredNorm() < fitness2;
      }
    });
    Partial total;  // summed in block order: deterministic
    for (const Partial& p : partials) {
      total.hessian += p.hessian;
      total.gradient += p.gradient;
      total.cost += p.cost;
      total.squared_error += p.squared_error;
      total.count += p.count;
      total.close += p.close;
    }
    total.hessian.bottomLeftCorner<3, 3>() = total.hessian.topRightCorner<3, 3>().transpose();
    return total;
  }

 private:
  const RegistrationCloud& source_;
  const RegistrationCloud& target_;
  const IcpOptions& options_;
  std::unique_ptr<PointKdTree> tree_;
  std::vector<Eigen::Matrix3d> source_covariances_, target_covariances_;
  std::vector<long> correspondences_;  // per source point; -1 = none
  // Per source point with a correspondence: where its last search was made from, and how far from
  // there every target point but its match is at least (correspond()).
  std::vector<Eigen::Vector3d> searched_at_;
  std::vector<double> clear_;
  float median_confidence_ = 1.f;
};

// The source points of each coarse-to-fine level: every stride-th point (a deterministic, uniform
// subsample of a panorama's pixel order), the last level all of them.
std::vector<std::vector<std::uint32_t>> level_subsets(std::size_t n, const IcpOptions& options) {
  std::vector<std::vector<std::uint32_t>> levels;
  for (int level = options.coarse_levels; level >= 1; --level) {
    std::size_t stride = 1;
    for (int k = 0; k < level; ++k) stride *= std::size_t(options.coarse_stride);
    if (n / stride < std::size_t(options.coarse_min_points)) continue;
    std::vector<std::uint32_t> subset;
    subset.reserve(n / stride + 1);
    for (std::size_t i = 0; i < n; i += stride) subset.push_back(std::uint32_t(i));
    levels.push_back(std::move(subset));
  }
  std::vector<std::uint32_t> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = std::uint32_t(i);
  levels.push_back(std::move(all));
  return levels;
}

}  // namespace

IcpResult register_icp(const RegistrationCloud& source, const RegistrationCloud& target,
                       const Rigid3d& initial_target_from_source, const IcpOptions& options) {
  options.check();
  check_cloud(source, "source", options.method);
  check_cloud(target, "target", options.method);
  if (source.points.size() > std::numeric_limits<std::uint32_t>::max())
    throw make_error("", "source cloud", "has more than 2^32 points");
  IcpResult result;
  result.target_from_source = initial_target_from_source;
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    auto clock = std::chrono::steady_clock::now();
    Problem problem(source, target, options);
    const std::vector<std::vector<std::uint32_t>> levels = level_subsets(source.points.size(), options);
    result.timings.setup_s += seconds_since(clock);
    for (std::size_t level = 0; level < levels.size(); ++level) {
      const bool finest = level + 1 == levels.size();
      // Coarse levels only bring the pose near the minimum; the finest level decides convergence.
      const double loosen = finest ? 1.0 : options.coarse_tolerance_scale;
      double cost_before = std::numeric_limits<double>::infinity(), cost_two_before = cost_before;
      for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
        clock = std::chrono::steady_clock::now();
        problem.correspond(result.target_from_source, levels[level]);
        result.timings.correspondence_s += seconds_since(clock);
        clock = std::chrono::steady_clock::now();
        const Partial system = problem.linearise(result.target_from_source, levels[level]);
        result.timings.linearise_s += seconds_since(clock);
        ++result.iterations;
        if (finest) result.cost_history.push_back(system.cost);
        if (system.count < 6)
          throw make_error(
              "", "registration",
              "fewer than 6 correspondences: no overlap within " + std::to_string(options.max_correspondence_m) + " m");
        clock = std::chrono::steady_clock::now();
        const Eigen::Matrix<double, 6, 1> step = -system.hessian.ldlt().solve(system.gradient);
        if (!step.allFinite()) throw make_error("", "registration", "degenerate system (the overlap constrains no pose)");
        const Rigid3d increment = make_rigid(so3_exp(step.head<3>()), step.tail<3>());
        result.target_from_source = increment * result.target_from_source;
        result.timings.solve_s += seconds_since(clock);
        const bool small_step = step.head<3>().norm() < loosen * options.convergence_rotation_rad &&
                                step.tail<3>().norm() < loosen * options.convergence_translation_m;
        // A nearly small step while the objective repeats the value of two steps before: the pose
        // sways between two correspondence sets (seen on coarse panoramas: 2.5e-7 rad back and
        // forth, the objective alternating) and further steps cannot improve it.
        const bool settled =
            std::abs(system.cost - cost_two_before) <= options.convergence_relative_cost * system.cost &&
            step.head<3>().norm() < options.coarse_tolerance_scale * loosen * options.convergence_rotation_rad &&
            step.tail<3>().norm() < options.coarse_tolerance_scale * loosen * options.convergence_translation_m;
        cost_two_before = cost_before;
        cost_before = system.cost;
        if (small_step || settled) {
          result.converged = finest;
          break;
        }
      }
    }
    clock = std::chrono::steady_clock::now();
    problem.correspond(result.target_from_source, levels.back());
    result.timings.correspondence_s += seconds_since(clock);
    clock = std::chrono::steady_clock::now();
    const Partial final_state = problem.linearise(result.target_from_source, levels.back());
    result.timings.linearise_s += seconds_since(clock);
    result.correspondences = final_state.count;
    result.inlier_fraction = double(final_state.count) / double(source.points.size());
    result.fitness = double(final_state.close) / double(source.points.size());
    result.rmse_m = final_state.count ? std::sqrt(final_state.squared_error / double(final_state.count)) : 0.0;
  });
  if (result.fitness < options.min_fitness)
    throw make_error("", "registration",
                     "failed: only " + std::to_string(int(std::lround(100 * result.fitness))) +
                         "% of the source points lie within " + std::to_string(options.fitness_distance_m) +
                         " m of the target at the end (minimum " +
                         std::to_string(int(std::lround(100 * options.min_fitness))) +
                         "%); the initial guess is probably wrong");
  return result;
}

}  // namespace panoscan
