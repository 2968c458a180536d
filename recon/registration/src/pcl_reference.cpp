// PCL's GICP is compiled entirely in the including file (about 20 s and 1 GB at -O3): it lives
// in this one translation unit only.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

#include "panoscan/core/error.h"
#include "panoscan/recon/outside_references.h"

namespace panoscan {

IcpResult register_pcl_gicp(const RegistrationCloud& source, const RegistrationCloud& target,
                            const Rigid3d& initial_target_from_source, const IcpOptions& options) {
  options.check();
  if (source.points.empty() || target.points.empty()) throw make_error("", "registration", "empty cloud");
  auto to_pcl = [](const std::vector<Eigen::Vector3d>& points) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->reserve(points.size());
    for (const auto& p : points) cloud->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
    return cloud;
  };
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setInputSource(to_pcl(source.points));
  gicp.setInputTarget(to_pcl(target.points));
  gicp.setMaxCorrespondenceDistance(options.max_correspondence_m);
  gicp.setMaximumIterations(options.max_iterations);
  gicp.setTransformationEpsilon(1e-8);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  gicp.align(aligned, initial_target_from_source.matrix().cast<float>());
  IcpResult result;
  result.target_from_source.matrix() = gicp.getFinalTransformation().cast<double>();
  // Re-orthonormalise: the float matrix drifts from a rotation by ~1e-7.
  result.target_from_source.linear() =
      Eigen::Quaterniond(result.target_from_source.linear()).normalized().toRotationMatrix();
  result.converged = gicp.hasConverged();
  result.iterations = options.max_iterations;  // PCL does not report the count
  result.rmse_m = std::sqrt(gicp.getFitnessScore(options.max_correspondence_m));
  return result;
}

}  // namespace panoscan
