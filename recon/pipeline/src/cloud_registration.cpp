#include "panoscan/recon/cloud_registration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "panoscan/core/error.h"

namespace panoscan {

namespace {

// Voxel-grid means (deterministic: voxels in the order of their integer keys).
void voxel_average(const CloudFile& file, double voxel_m, bool with_covariance, RegistrationCloud& out) {
  const std::size_t n = file.points.size();
  std::vector<std::array<std::int64_t, 3>> keys(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      const double cell = std::floor(file.points[i][k] / voxel_m);
      if (!(std::abs(cell) < 4e18))
        throw make_error(file.path, "registration.voxel_m", "a point lies too far out for a grid of this voxel size");
      keys[i][k] = static_cast<std::int64_t>(cell);
    }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  for (std::size_t start = 0; start < n;) {
    std::size_t end = start;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    while (end < n && keys[order[end]] == keys[order[start]]) {
      sum += file.points[order[end]];
      if (with_covariance) covariance += file.covariances[order[end]];
      ++end;
    }
    const double count = double(end - start);
    out.points.push_back(sum / count);
    // The covariance of the mean of independent measurements.
    if (with_covariance) out.measurement_covariances.push_back(covariance / (count * count));
    start = end;
  }
}

}  // namespace

CloudRegistrationOptions cloud_registration_options_from_config(Config& config) {
  const PairRegistrationOptions pair = pair_registration_options_from_config(config);
  CloudRegistrationOptions options;
  options.icp = pair.icp;
  options.surface = pair.cloud.surface;
  options.min_fitness = pair.min_fitness;
  options.voxel_m = config.get_double("registration.voxel_m", options.voxel_m, 0.0, 100.0);
  return options;
}

Eigen::Vector3d cloud_file_viewpoint(const CloudFile& file) {
  return file.has_viewpoint ? file.viewpoint : Eigen::Vector3d::Zero();
}

RegistrationCloud cloud_file_registration_cloud(const CloudFile& file, double voxel_m, bool with_covariance,
                                                const SurfaceOptions& surface) {
  with_covariance = with_covariance && !file.covariances.empty();
  if (with_covariance && file.covariances.size() != file.points.size())
    throw make_error(file.path, "covariances", "one per point expected");
  RegistrationCloud cloud;
  if (voxel_m > 0) {
    voxel_average(file, voxel_m, with_covariance, cloud);
  } else {
    cloud.points = file.points;
    if (with_covariance) cloud.measurement_covariances = file.covariances;
  }
  if (cloud.points.size() < 10)
    throw make_error(file.path, "points",
                     fmt::format("{} usable points (of {} in the file{}{}); registration needs at least 10",
                                 cloud.points.size(), file.declared_points,
                                 file.dropped_invalid ? fmt::format(", {} NaN", file.dropped_invalid) : "",
                                 voxel_m > 0 ? fmt::format(", voxel {} m", voxel_m) : ""));
  prepare_surface(cloud, cloud_file_viewpoint(file), surface);
  return cloud;
}

CloudPairRegistration register_cloud_files(const CloudFile& source, const CloudFile& target, const Rigid3d& initial,
                                           const CloudRegistrationOptions& options) {
  const std::string pair = source.path + " -> " + target.path;
  if (options.icp.method == IcpMethod::kGicpNoiseModel)
    throw make_error(pair, "registration.method",
                     "gicp-def models a PrimeSense depth camera (Handa et al.), which a point-cloud file does not "
                     "say it came from; use gicp-ours (the file's per-point covariance) or gicp");
  CloudPairRegistration result;
  IcpOptions icp = options.icp;
  const bool measured = icp.method == IcpMethod::kGicpMeasured;
  const bool source_has = !source.covariances.empty(), target_has = !target.covariances.empty();
  if (measured) {
    result.source_covariance = source_has;
    result.target_covariance = target_has;
    if (!source_has && !target_has) {
      icp.method = IcpMethod::kGicp;
      result.covariance_note =
          "neither file carries a per-point covariance or variance (cov_xx..cov_zz, variance, sigma): fell back to "
          "plain GICP, the surface covariances only";
    } else if (source_has && target_has) {
      result.covariance_note = "the files' per-point covariances (source: " + source.uncertainty +
                               ", target: " + target.uncertainty + ") added to the surface covariances";
    } else {
      const CloudFile& without = source_has ? target : source;
      result.covariance_note = std::string(source_has ? "source" : "target") + "'s per-point covariance (" +
                               (source_has ? source.uncertainty : target.uncertainty) + ") added; " +
                               (source_has ? "target " : "source ") + without.path +
                               " carries none, so it has its surface covariance only (as plain GICP)";
    }
  } else {
    result.covariance_note = std::string(to_string(icp.method)) + " uses no measurement covariance";
  }
  result.method_used = icp.method;

  // Each throws naming its file.
  RegistrationCloud source_cloud = cloud_file_registration_cloud(source, options.voxel_m, measured, options.surface);
  RegistrationCloud target_cloud = cloud_file_registration_cloud(target, options.voxel_m, measured, options.surface);
  // One side without a covariance adds none: zero measurement covariance, its surface covariance only.
  if (measured && icp.method == IcpMethod::kGicpMeasured) {
    if (source_cloud.measurement_covariances.empty())
      source_cloud.measurement_covariances.assign(source_cloud.points.size(), Eigen::Matrix3d::Zero());
    if (target_cloud.measurement_covariances.empty())
      target_cloud.measurement_covariances.assign(target_cloud.points.size(), Eigen::Matrix3d::Zero());
  }
  result.source_points = source_cloud.points.size();
  result.target_points = target_cloud.points.size();
  try {
    result.icp = register_icp(source_cloud, target_cloud, initial, icp);
  } catch (const Error& e) {
    throw make_error(pair, "", e.what());
  }
  result.target_from_source = result.icp.target_from_source;
  result.overlap = surface_overlap(source_cloud, target_cloud, result.target_from_source, icp.max_correspondence_m,
                                   icp.fitness_distance_m);
  if (result.overlap < options.min_fitness)
    throw make_error(pair, "registration",
                     fmt::format("failed: the clouds do not overlap at the final pose (only {}% of the source points "
                                 "within {} mm of the target's surface, registration.min_fitness {}%); a better "
                                 "--initial pose?",
                                 std::lround(100 * result.overlap), std::lround(1000 * icp.fitness_distance_m),
                                 std::lround(100 * options.min_fitness)));
  return result;
}

}  // namespace panoscan
