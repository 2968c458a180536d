// The ICP family of Table 4 as one Gauss-Newton loop; methods differ in the per-correspondence
// metric M_i and in the choice of correspondence (see registration.h).
#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <tbb/parallel_for.h>
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

class Problem {
 public:
  Problem(const RegistrationCloud& source, const RegistrationCloud& target, const IcpOptions& options)
      : source_(source), target_(target), options_(options), tree_(target.points) {
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
      default: {
        // Eq. 8/9: combined covariance R C_s R^T + C_t, inverted.
        Eigen::Matrix3d source_cov = source_.surface_covariances[i];
        Eigen::Matrix3d target_cov = target_.surface_covariances[j];
        if (uses_measurement_covariance(options_.method)) {
          source_cov += source_.measurement_covariances[i];
          target_cov += target_.measurement_covariances[j];
        }
        return (rotation * source_cov * rotation.transpose() + target_cov).inverse();
      }
    }
  }

  // Correspondence of source point i placed at q; -1 if none within the distance.
  long correspond(std::size_t i, const Eigen::Vector3d& q, const Eigen::Matrix3d& rotation, Eigen::Matrix3d* m) const {
    const double max_d2 = options_.max_correspondence_m * options_.max_correspondence_m;
    if (options_.method != IcpMethod::kAnisotropic) {
      double d2 = 0;
      const long j = tree_.nearest_within(q, options_.max_correspondence_m, &d2);
      if (j >= 0) *m = metric(i, std::size_t(j), rotation);
      return j;
    }
    // Anisotropic ICP: the Mahalanobis-nearest among the Euclidean candidates.
    std::uint32_t indices[32];
    double squared[32];
    const std::size_t k = std::min<std::size_t>(options_.anisotropic_candidates, 32);
    const std::size_t found = tree_.knn(q, k, indices, squared);
    long best = -1;
    double best_cost = 0;
    for (std::size_t c = 0; c < found; ++c) {
      if (squared[c] > max_d2) break;
      const Eigen::Matrix3d candidate_metric = metric(i, indices[c], rotation);
      const Eigen::Vector3d d = target_.points[indices[c]] - q;
      const double cost = d.dot(candidate_metric * d);
      if (best < 0 || cost < best_cost) {
        best = indices[c];
        best_cost = cost;
        *m = candidate_metric;
      }
    }
    return best;
  }

  Partial linearise(const Rigid3d& target_from_source) const {
    const std::size_t n = source_.points.size();
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    std::vector<Partial> partials(blocks);
    const Eigen::Matrix3d rotation = target_from_source.linear();
    const double fitness2 = options_.fitness_distance_m * options_.fitness_distance_m;
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      Partial& partial = partials[b];
      const std::size_t end = std::min(n, (b + 1) * kBlock);
      for (std::size_t i = b * kBlock; i < end; ++i) {
        const Eigen::Vector3d q = target_from_source * source_.points[i];
        Eigen::Matrix3d m;
        const long j = correspond(i, q, rotation, &m);
        if (j < 0) continue;
        const Eigen::Vector3d d = target_.points[j] - q;
        // d(xi) = b - exp(xi) q ~ d + [ [q]x  -I ] xi  (left perturbation, xi = (omega, v)).
        Eigen::Matrix<double, 3, 6> jacobian;
        jacobian.leftCols<3>() = skew(q);
        jacobian.rightCols<3>() = -Eigen::Matrix3d::Identity();
        const Eigen::Matrix<double, 6, 3> jt_m = jacobian.transpose() * m;
        partial.hessian += jt_m * jacobian;
        partial.gradient += jt_m * d;
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
    return total;
  }

 private:
  const RegistrationCloud& source_;
  const RegistrationCloud& target_;
  const IcpOptions& options_;
  PointKdTree tree_;
  float median_confidence_ = 1.f;
};

}  // namespace

IcpResult register_icp(const RegistrationCloud& source, const RegistrationCloud& target,
                       const Rigid3d& initial_target_from_source, const IcpOptions& options) {
  options.check();
  check_cloud(source, "source", options.method);
  check_cloud(target, "target", options.method);
  IcpResult result;
  result.target_from_source = initial_target_from_source;
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    const Problem problem(source, target, options);
    for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
      const Partial system = problem.linearise(result.target_from_source);
      result.iterations = iteration + 1;
      result.cost_history.push_back(system.cost);
      if (system.count < 6)
        throw make_error(
            "", "registration",
            "fewer than 6 correspondences: no overlap within " + std::to_string(options.max_correspondence_m) + " m");
      const Eigen::Matrix<double, 6, 1> step = -system.hessian.ldlt().solve(system.gradient);
      if (!step.allFinite()) throw make_error("", "registration", "degenerate system (the overlap constrains no pose)");
      const Rigid3d increment = make_rigid(so3_exp(step.head<3>()), step.tail<3>());
      result.target_from_source = increment * result.target_from_source;
      if (step.head<3>().norm() < options.convergence_rotation_rad &&
          step.tail<3>().norm() < options.convergence_translation_m) {
        result.converged = true;
        break;
      }
    }
    const Partial final_state = problem.linearise(result.target_from_source);
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
