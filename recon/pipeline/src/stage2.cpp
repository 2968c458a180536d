#include "panoscan/recon/stage2.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/config.h"
#include "panoscan/core/kdtree.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/recon/point_covariance.h"

namespace panoscan {

namespace {

// Handa et al.'s depth std (docs/ARCHITECTURE.md §4.1): sigma_Z = Z^2 / 351.3 / 3 (radial ~ z for the centre rays).
double handa_model_sigma(double depth_m) { return depth_m * depth_m / 351.3 / 3.0; }

// The median measured sigma_z of the pixels that pass the filters (kConstant's default value).
double median_usable_sigma(const Panorama& panorama, const PanoramaCloudOptions& options) {
  std::vector<float> sigmas;
  const std::size_t n = panorama.depth.data.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (!(panorama.depth.data[i] > 0) || panorama.count.data[i] < options.min_observations) continue;
    const float sigma = std::sqrt(std::max(0.f, panorama.variance.data[i]));
    if (sigma <= options.max_sigma_m) sigmas.push_back(sigma);
  }
  if (sigmas.empty()) return 0.0;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

}  // namespace

double surface_overlap(const RegistrationCloud& source, const RegistrationCloud& target,
                       const Rigid3d& target_from_source, double max_correspondence_m, double max_plane_distance_m) {
  if (source.points.empty() || target.normals.size() != target.points.size()) return 0.0;
  const PointKdTree tree(target.points);
  std::size_t close = 0;
  for (const Eigen::Vector3d& p : source.points) {
    const Eigen::Vector3d q = target_from_source * p;
    const long j = tree.nearest_within(q, max_correspondence_m);
    if (j >= 0 && std::abs(target.normals[j].dot(q - target.points[j])) < max_plane_distance_m) ++close;
  }
  return double(close) / double(source.points.size());
}

const char* to_string(DepthCovarianceModel model) {
  switch (model) {
    case DepthCovarianceModel::kMeasured: return "measured";
    case DepthCovarianceModel::kHandaModel: return "handa-model";
    case DepthCovarianceModel::kConstant: return "constant";
  }
  return "?";
}

RegistrationCloud panorama_registration_cloud(const Panorama& panorama, const PanoramaCloudOptions& options,
                                              std::vector<std::size_t>* pixels) {
  const Equirectangular& pano = panorama.pano;
  const int width = pano.width(), height = pano.height;
  const int stride = std::max(1, options.pixel_stride);
  const double sigma_angle = options.angular_sigma_px * M_PI / height;  // Eq. 9's sigma_phi = sigma_theta
  const double constant_sigma = options.covariance != DepthCovarianceModel::kConstant ? 0.0
                                : options.constant_sigma_m > 0                        ? options.constant_sigma_m
                                                               : median_usable_sigma(panorama, options);
  RegistrationCloud cloud;
  // The sampled pixels form a grid (every stride-th row and column): prepare_surface takes each
  // point's neighbours from the grid window around it.
  cloud.grid_width = (width + stride - 1) / stride;
  cloud.grid_height = (height + stride - 1) / stride;
  if (pixels) pixels->clear();
  for (int v = 0; v < height; v += stride)
    for (int u = 0; u < width; u += stride) {
      const double depth = panorama.depth.at(u, v);
      if (!(depth > 0)) continue;
      const double count = panorama.count.at(u, v);
      const double sigma_measured = std::sqrt(std::max(0.0, double(panorama.variance.at(u, v))));
      if (count < options.min_observations || sigma_measured > options.max_sigma_m) continue;
      const double sigma = options.covariance == DepthCovarianceModel::kMeasured
                               ? std::max(options.standard_error ? sigma_measured / std::sqrt(count) : sigma_measured,
                                          1e-4)  // a pixel is never exact
                           : options.covariance == DepthCovarianceModel::kHandaModel ? handa_model_sigma(depth)
                                                                                     : std::max(constant_sigma, 1e-4);
      cloud.points.push_back(pano.direction(u, v) * depth);
      cloud.measurement_covariances.push_back(equirectangular_point_covariance(
          2 * M_PI * (u + 0.5) / width, M_PI * (v + 0.5) / height, depth, sigma_angle, sigma));
      cloud.confidence.push_back(float(count));
      cloud.grid_cells.push_back(std::uint32_t((v / stride) * cloud.grid_width + u / stride));
      if (pixels) pixels->push_back(std::size_t(v) * width + u);
    }
  if (cloud.points.size() < 10)
    throw make_error("", "panorama",
                     "has fewer than 10 usable pixels (depth, >= " + std::to_string(options.min_observations) +
                         " observations, sigma_z <= " + std::to_string(options.max_sigma_m) + " m)");
  prepare_surface(cloud, Eigen::Vector3d::Zero(), options.surface);
  return cloud;
}

namespace {

ImageU8 colour_u8(const ImageF32& colour) {
  ImageU8 out(colour.width, colour.height, 3);
  for (std::size_t i = 0; i < colour.data.size(); ++i)
    out.data[i] = static_cast<std::uint8_t>(std::clamp(colour.data[i] * 255.f + 0.5f, 0.f, 255.f));
  return out;
}

}  // namespace

FeatureAlignment panorama_feature_guess(const Panorama& source, const Panorama& target,
                                        const FeatureAlignmentOptions& options) {
  const ImageU8 source_rgb = colour_u8(source.colour), target_rgb = colour_u8(target.colour);
  return align_panorama_features({&source_rgb, &source.depth}, {&target_rgb, &target.depth}, options);
}

PreparedPanorama prepare_panorama_for_registration(const Panorama& panorama, const PairRegistrationOptions& options,
                                                   const std::string& name) {
  PreparedPanorama prepared;
  prepared.name = name;
  prepared.height = panorama.pano.height;
  try {
    prepared.cloud = panorama_registration_cloud(panorama, options.cloud);
  } catch (const Error& e) {
    throw make_error(name, "", e.what());
  }
  const ImageU8 rgb = colour_u8(panorama.colour);
  prepared.features = detect_panorama_features({&rgb, &panorama.depth}, options.features, name.c_str());
  return prepared;
}

RunnerUpVerdict judge_runner_up(double best_overlap, int best_evidence, double runner_up_overlap,
                                int runner_up_evidence, const PairRegistrationOptions& options) {
  // The runner-up fits the geometry clearly better: ORB's majority was the wrong one.
  if (runner_up_overlap > best_overlap + options.ambiguity_margin) return RunnerUpVerdict::kTakeRunnerUp;
  if (runner_up_overlap < best_overlap - options.ambiguity_margin) return RunnerUpVerdict::kKeepBest;
  // The geometry cannot choose. The appearance can when it is one-sided and agrees with the
  // geometry's (slight) preference: a runner-up found among the matches the best leaves unexplained,
  // with a few percent of its evidence, is chance consistency, not a mirror image.
  if (runner_up_overlap <= best_overlap &&
      double(runner_up_evidence) < options.ambiguity_evidence_fraction * double(best_evidence))
    return RunnerUpVerdict::kDismissed;
  return RunnerUpVerdict::kAmbiguous;
}

nlohmann::json runner_up_to_json(const PairRegistration& r) {
  if (!r.alternative_refined) return nullptr;
  const Rigid3d between = r.alternative_target_from_source.inverse() * r.target_from_source;
  return {{"orb_inliers", r.guess.alternative_inliers},
          {"guided_matches", r.guess.alternative_guided_matches},
          {"evidence", r.guess.alternative_evidence()},
          {"dismissed", r.alternative_dismissed},
          {"target_from_source", pose_to_json(r.alternative_target_from_source)},
          {"overlap", r.alternative_overlap},
          {"consistent_matches", r.alternative_consistent_matches},
          {"rotation_from_result_deg", rad2deg(rotation_angle(between.linear()))},
          {"translation_from_result_m", between.translation().norm()}};
}

PairRegistration register_panorama_pair(const Panorama& source, const Panorama& target,
                                        const PairRegistrationOptions& options, const Rigid3d* given_initial,
                                        const std::string& source_name, const std::string& target_name) {
  if (source.pano.height != target.pano.height)
    throw make_error(source_name + " -> " + target_name, "size",
                     "the panoramas differ in size (" + std::to_string(source.pano.width()) + "x" +
                         std::to_string(source.pano.height) + " and " + std::to_string(target.pano.width()) + "x" +
                         std::to_string(target.pano.height) + "); build both with the same height H");
  // Usable pixels first: a panorama without any is reported as such, not as a feature failure.
  const PreparedPanorama prepared_source = prepare_panorama_for_registration(source, options, source_name);
  const PreparedPanorama prepared_target = prepare_panorama_for_registration(target, options, target_name);
  return register_panorama_pair(prepared_source, prepared_target, options, given_initial);
}

PairRegistration register_panorama_pair(const PreparedPanorama& source, const PreparedPanorama& target,
                                        const PairRegistrationOptions& options, const Rigid3d* given_initial) {
  const std::string pair = source.name + " -> " + target.name;
  if (source.height != target.height)
    throw make_error(pair, "size",
                     "the panoramas differ in size (H = " + std::to_string(source.height) + " and " +
                         std::to_string(target.height) + "); build both with the same height H");
  const RegistrationCloud& source_cloud = source.cloud;
  const RegistrationCloud& target_cloud = target.cloud;
  PairRegistration result;
  result.guess = align_panorama_features(source.features, target.features, options.features);
  Rigid3d initial;
  if (given_initial) {
    initial = *given_initial;
  } else if (result.guess.success) {
    initial = result.guess.target_from_source;
  } else {
    throw make_error(pair, "initial guess",
                     "ORB feature alignment failed (" + result.guess.failure + "); give an initial pose");
  }
  try {
    result.icp = register_icp(source_cloud, target_cloud, initial, options.icp);
  } catch (const Error& e) {
    throw make_error(pair, "", e.what());
  }
  result.target_from_source = result.icp.target_from_source;
  result.overlap = surface_overlap(source_cloud, target_cloud, result.target_from_source,
                                   options.icp.max_correspondence_m, options.icp.fitness_distance_m);
  if (result.overlap < options.min_fitness)
    throw make_error(pair, "registration",
                     "failed: the panoramas do not overlap at the final pose (only " +
                         std::to_string(int(std::lround(100 * result.overlap))) + "% of the source points within " +
                         std::to_string(int(std::lround(1000 * options.icp.fitness_distance_m))) +
                         " mm of the target's surface, minimum " +
                         std::to_string(int(std::lround(100 * options.min_fitness))) + "%)");
  // Ambiguity: the runner-up hypothesis refined the same way. Two distinct poses with about the same
  // overlap mean a room the geometry cannot place this scan in (mirror symmetry, repeated bays).
  if (!given_initial && result.guess.alternative_inliers > 0) {
    IcpResult alternative;
    try {
      alternative = register_icp(source_cloud, target_cloud, result.guess.alternative_target_from_source, options.icp);
      result.alternative_refined = true;
      result.alternative_target_from_source = alternative.target_from_source;
      result.alternative_overlap = surface_overlap(source_cloud, target_cloud, alternative.target_from_source,
                                                   options.icp.max_correspondence_m, options.icp.fitness_distance_m);
      result.alternative_consistent_matches =
          count_consistent_matches(result.guess, alternative.target_from_source, options.consistency_threshold_m);
    } catch (const Error&) {
      // The runner-up does not converge (too little overlap at it): no alternative.
    }
    if (result.alternative_refined &&
        !same_registration_basin(result.alternative_target_from_source, result.target_from_source)) {
      // (Within the loop-closure tolerances of placement.h the two are one basin: no ambiguity.)
      const Rigid3d between = result.alternative_target_from_source.inverse() * result.target_from_source;
      const double rotation_deg = rad2deg(rotation_angle(between.linear()));
      const double translation_m = between.translation().norm();
      const int evidence = result.guess.evidence(), alternative_evidence = result.guess.alternative_evidence();
      switch (judge_runner_up(result.overlap, evidence, result.alternative_overlap, alternative_evidence, options)) {
        case RunnerUpVerdict::kKeepBest: break;
        case RunnerUpVerdict::kTakeRunnerUp:
          log_warn(
              fmt::format("{}: the runner-up ORB hypothesis ({} matches) fits better after ICP (overlap {:.3f} "
                          "against {:.3f}); taking it",
                          pair, result.guess.alternative_inliers, result.alternative_overlap, result.overlap));
          std::swap(result.target_from_source, result.alternative_target_from_source);
          std::swap(result.overlap, result.alternative_overlap);
          std::swap(result.icp, alternative);
          result.alternative_consistent_matches = count_consistent_matches(
              result.guess, result.alternative_target_from_source, options.consistency_threshold_m);
          std::swap(result.guess.target_from_source, result.guess.alternative_target_from_source);
          std::swap(result.guess.inliers, result.guess.alternative_inliers);
          std::swap(result.guess.guided_matches, result.guess.alternative_guided_matches);
          break;
        case RunnerUpVerdict::kDismissed:
          result.alternative_dismissed = true;
          log_info(
              fmt::format("{}: a runner-up {:.1f} deg and {:.2f} m away fits about as well (overlap {:.3f} "
                          "against {:.3f}) but holds {} of the best's {} feature evidence (below "
                          "registration.ambiguity_evidence_fraction {:.2f}): kept the best",
                          pair, rotation_deg, translation_m, result.alternative_overlap, result.overlap,
                          alternative_evidence, evidence, options.ambiguity_evidence_fraction));
          break;
        case RunnerUpVerdict::kAmbiguous:
          throw make_error(
              pair, "registration",
              fmt::format("ambiguous: two poses {:.1f} deg and {:.2f} m apart fit about equally (overlap {:.3f} with "
                          "feature evidence {}, {:.3f} with {}; registration.ambiguity_margin {:.2f}, "
                          "ambiguity_evidence_fraction {:.2f}) - a symmetric or repeating room? Give an initial "
                          "pose (recon register --initial)",
                          rotation_deg, translation_m, result.overlap, evidence, result.alternative_overlap,
                          alternative_evidence, options.ambiguity_margin, options.ambiguity_evidence_fraction));
      }
    }
  }
  // Verification: the geometry alone cannot tell a wrong local minimum in a box-like room; the
  // feature matches can (a wrong pose explains few of them).
  // A given pose at the ORB runner-up (the true pose of a symmetric pair, say) is held to the
  // runner-up's matches, not to the majority it contradicts.
  // The evidence counts the guided matches too (feature_alignment.h), which the matched points hold.
  int verified = result.guess.evidence();
  if (given_initial && result.guess.alternative_inliers > 0) {
    if (same_registration_basin(result.guess.alternative_target_from_source, result.target_from_source))
      verified = result.guess.alternative_evidence();
  }
  if (verified >= options.features.min_inliers) {
    result.consistent_matches =
        count_consistent_matches(result.guess, result.target_from_source, options.consistency_threshold_m);
    if (result.consistent_matches < options.min_consistent_fraction * verified)
      throw make_error(pair, "registration",
                       "failed: the final pose explains only " + std::to_string(result.consistent_matches) + " of " +
                           std::to_string(verified) + " verified feature matches (initial guess wrong?)");
  }
  return result;
}

PanoramaPoints panorama_integration_points(const Panorama& panorama, const Rigid3d& world_from_panorama,
                                           const PanoramaCloudOptions& options) {
  // Eq. 10-11 weigh each point by its covariance as a position uncertainty in m^2: the surface
  // shape scaled by the neighbourhood's spread plus Eq. 9's measurement covariance. Registration's
  // unit-form surface covariance (1 m^2 in the plane) is a cost-function device, not an uncertainty.
  PanoramaCloudOptions metric = options;
  metric.surface.metric_scale = true;
  std::vector<std::size_t> pixels;
  const RegistrationCloud cloud = panorama_registration_cloud(panorama, metric, &pixels);
  PanoramaPoints points;
  points.world_from_panorama = world_from_panorama;
  points.points = cloud.points;
  points.covariances.resize(cloud.points.size());
  points.colours.resize(cloud.points.size());
  const int width = panorama.pano.width();
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    points.covariances[i] = cloud.surface_covariances[i] + cloud.measurement_covariances[i];  // Eq. 9's Omega^A
    const int u = int(pixels[i] % width), v = int(pixels[i] / width);
    for (int c = 0; c < 3; ++c)
      points.colours[i][c] =
          static_cast<std::uint8_t>(std::clamp(panorama.colour.at(u, v, c) * 255.f + 0.5f, 0.f, 255.f));
  }
  return points;
}

PairRegistrationOptions pair_registration_options_from_config(Config& config) {
  PairRegistrationOptions options;
  IcpOptions& icp = options.icp;
  icp.method = icp_method_from_string(
      config.get_string("registration.method", to_string(icp.method),
                        {"p2point", "p2plane", "p2plane-curv", "gicp", "anisotropic", "gicp-def", "gicp-ours"}));
  icp.max_correspondence_m =
      config.get_double("registration.max_correspondence_m", icp.max_correspondence_m, 1e-3, 10.0);
  icp.max_iterations = config.get_int("registration.max_iterations", icp.max_iterations, 1, 1000);
  icp.coarse_levels = config.get_int("registration.coarse_levels", icp.coarse_levels, 0, 8);
  options.min_fitness = config.get_double("registration.min_fitness", options.min_fitness, 0.0, 1.0);
  options.ambiguity_margin = config.get_double("registration.ambiguity_margin", options.ambiguity_margin, 0.0, 1.0);
  options.ambiguity_evidence_fraction =
      config.get_double("registration.ambiguity_evidence_fraction", options.ambiguity_evidence_fraction, 0.0, 1.0);
  icp.threads = config.get_int("threads", 0, 0, 1024);
  PanoramaCloudOptions& cloud = options.cloud;
  // "Def." (Table 4) means the general noise model in place of the measured variance.
  const std::string covariance = config.get_string(
      "registration.covariance", icp.method == IcpMethod::kGicpNoiseModel ? "handa-model" : "measured",
      {"measured", "handa-model", "constant"});
  cloud.covariance = covariance == "measured"      ? DepthCovarianceModel::kMeasured
                     : covariance == "handa-model" ? DepthCovarianceModel::kHandaModel
                                                   : DepthCovarianceModel::kConstant;
  cloud.constant_sigma_m = config.get_double("registration.constant_sigma_m", cloud.constant_sigma_m, 0.0, 1.0);
  cloud.pixel_stride = config.get_int("registration.pixel_stride", cloud.pixel_stride, 1, 64);
  cloud.min_observations = config.get_int("registration.min_observations", cloud.min_observations, 1, 1000);
  cloud.max_sigma_m = config.get_double("registration.max_sigma_m", cloud.max_sigma_m, 1e-4, 10.0);
  cloud.angular_sigma_px = config.get_double("registration.angular_sigma_px", cloud.angular_sigma_px, 0.0, 100.0);
  cloud.standard_error = config.get_string("registration.sigma_z", "spread", {"spread", "standard-error"}) ==
                         "standard-error";
  cloud.surface.metric_scale =
      config.get_string("registration.surface_covariance", cloud.surface.metric_scale ? "metric" : "unit",
                        {"unit", "metric"}) == "metric";
  cloud.surface.threads = icp.threads;
  // The ORB + RANSAC initial guess (feature_alignment.h); checked as a whole by FeatureAlignmentOptions::check.
  FeatureAlignmentOptions& features = options.features;
  features.max_features = config.get_int("registration.features.max_features", features.max_features, 10, 1000000);
  features.ratio_test = config.get_double("registration.features.ratio_test", features.ratio_test, 1e-6, 1.0);
  features.max_hamming = config.get_int("registration.features.max_hamming", features.max_hamming, 1, 256);
  features.inlier_threshold_m =
      config.get_double("registration.features.inlier_threshold_m", features.inlier_threshold_m, 1e-4, 10.0);
  features.ransac_iterations =
      config.get_int("registration.features.ransac_iterations", features.ransac_iterations, 1, 10000000);
  features.min_inliers = config.get_int("registration.features.min_inliers", features.min_inliers, 3, 1000000);
  features.guided_max_hamming =
      config.get_int("registration.features.guided_max_hamming", features.guided_max_hamming, 0, 256);
  features.seed = config.get_u64("seed", 1);
  return options;
}

IntegrationOptions integration_options_from_config(Config& config) {
  IntegrationOptions options;
  options.method = merge_method_from_string(
      config.get_string("integration.method", to_string(options.method), {"map", "average", "align"}));
  options.weighting =
      config.get_string("integration.weighting", "information", {"information", "paper-inverse-sqrt"}) == "information"
          ? MapWeighting::kInformation
          : MapWeighting::kPaperInverseSqrt;
  options.threads = config.get_int("threads", 0, 0, 1024);
  return options;
}

}  // namespace panoscan
