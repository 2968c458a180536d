// Local surface of every point from its k nearest neighbours: the normal, the curvature and
// Generalized-ICP's plane-shaped covariance (Segal et al. 2009, §III-B).
#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/recon/registration.h"

namespace panoscan {

void prepare_surface(RegistrationCloud& cloud, const Eigen::Vector3d& viewpoint, const SurfaceOptions& options) {
  const std::size_t n = cloud.points.size();
  if (n == 0) throw make_error("", "registration cloud", "is empty");
  if (options.neighbours < 3) throw make_error("", "surface.neighbours", "must be at least 3");
  const PointKdTree tree(cloud.points);
  cloud.normals.assign(n, Eigen::Vector3d::UnitZ());
  cloud.curvature.assign(n, 0.f);
  cloud.surface_covariances.assign(n, Eigen::Matrix3d::Identity() * 1e-4);
  const std::size_t k = std::min<std::size_t>(options.neighbours, n);
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const tbb::blocked_range<std::size_t>& range) {
      std::vector<std::uint32_t> indices(k);
      std::vector<double> squared(k);
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const Eigen::Vector3d& p = cloud.points[i];
        const std::size_t found = tree.knn(p, k, indices.data(), squared.data());
        Eigen::Vector3d towards_viewpoint = viewpoint - p;
        if (towards_viewpoint.norm() < 1e-12) towards_viewpoint = Eigen::Vector3d::UnitZ();
        towards_viewpoint.normalize();
        if (found < 3) {
          cloud.normals[i] = towards_viewpoint;
          continue;
        }
        // One pass over the neighbours, relative to p (offsets of centimetres: no cancellation).
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
        for (std::size_t j = 0; j < found; ++j) {
          const Eigen::Vector3d d = cloud.points[indices[j]] - p;
          sum += d;
          outer += d * d.transpose();
        }
        const Eigen::Vector3d mean = sum / double(found);
        const Eigen::Matrix3d covariance = outer / double(found) - mean * mean.transpose();
        // The closed-form 3x3 solver (Eigen's computeDirect, several times faster than the
        // iterative one): the normal is the eigenvector of the clearly smallest eigenvalue, which
        // it resolves well; where the two in-plane eigenvalues are close their vectors are
        // arbitrary, but the plane-shaped covariance below does not depend on them.
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
        eigen.computeDirect(covariance);
        const Eigen::Vector3d values = eigen.eigenvalues().cwiseMax(0.0);  // ascending
        const Eigen::Matrix3d vectors = eigen.eigenvectors();
        Eigen::Vector3d normal = vectors.col(0);
        if (normal.dot(towards_viewpoint) < 0) normal = -normal;
        cloud.normals[i] = normal;
        const double total = values.sum();
        cloud.curvature[i] = total > 0 ? float(values[0] / total) : 0.f;
        // GICP: the point may slide within its plane but not across it: Segal et al.'s unit form
        // by default; metric_scale: scaled by the neighbourhood's in-plane variance (m^2).
        // registration.h compares the two.
        const double in_plane = options.metric_scale ? std::max(0.5 * (values[1] + values[2]), 1e-10) : 1.0;
        const Eigen::Vector3d shape(options.plane_epsilon * in_plane, in_plane, in_plane);
        cloud.surface_covariances[i] = vectors * shape.asDiagonal() * vectors.transpose();
      }
    });
  });
}

}  // namespace panoscan
