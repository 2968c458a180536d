#include "panoscan/recon/feature_alignment.h"

#include <algorithm>
#include <cmath>

#include "panoscan/core/error.h"
#include "panoscan/core/rigid_ransac.h"
#include "panoscan/recon/orb_features.h"

namespace panoscan {

void FeatureAlignmentOptions::check() const {
  if (max_features < 10) throw make_error("", "registration.features.max_features", "must be at least 10");
  if (!(ratio_test > 0 && ratio_test <= 1))
    throw make_error("", "registration.features.ratio_test", "must be in (0, 1]");
  if (max_hamming < 1 || max_hamming > 256)
    throw make_error("", "registration.features.max_hamming", "must be in [1, 256]");
  if (!(inlier_threshold_m > 0)) throw make_error("", "registration.features.inlier_threshold_m", "must be positive");
  if (ransac_iterations < 1) throw make_error("", "registration.features.ransac_iterations", "must be at least 1");
  if (min_inliers < 3) throw make_error("", "registration.features.min_inliers", "must be at least 3");
}

PanoramaFeatures detect_panorama_features(const PanoramaImages& images, const FeatureAlignmentOptions& options,
                                          const char* role) {
  options.check();
  if (!images.rgb || !images.radial_depth) throw make_error("", std::string(role) + " panorama", "missing images");
  const ImageU8& rgb = *images.rgb;
  const ImageF32& depth = *images.radial_depth;
  if (rgb.channels != 3 || rgb.width != 2 * rgb.height || depth.width != rgb.width || depth.height != rgb.height)
    throw make_error("", std::string(role) + " panorama",
                     "needs H x 2H colour (3 channels) and depth of the same size");
  OrbDetectorOptions orb;  // OpenCV's ORB defaults but the count
  orb.features = options.max_features;
  std::vector<OrbKeypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  detect_orb(rgb, orb, &keypoints, &descriptors);
  const Equirectangular pano{rgb.height};
  PanoramaFeatures features;
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const int x = std::clamp(int(std::lround(keypoints[i].u)), 0, rgb.width - 1);
    const int y = std::clamp(int(std::lround(keypoints[i].v)), 0, rgb.height - 1);
    const float z = depth.at(x, y);
    if (!(z > 0) || !std::isfinite(z)) continue;
    features.points.push_back(pano.direction(keypoints[i].u, keypoints[i].v) * double(z));
    features.descriptors.push_back(descriptors[i]);
  }
  return features;
}

FeatureAlignment align_panorama_features(const PanoramaImages& source, const PanoramaImages& target,
                                         const FeatureAlignmentOptions& options) {
  return align_panorama_features(detect_panorama_features(source, options, "source"),
                                 detect_panorama_features(target, options, "target"), options);
}

FeatureAlignment align_panorama_features(const PanoramaFeatures& from, const PanoramaFeatures& to,
                                         const FeatureAlignmentOptions& options) {
  options.check();
  FeatureAlignment result;
  result.source_features = int(from.points.size());
  result.target_features = int(to.points.size());
  if (from.points.size() < 3 || to.points.size() < 3) {
    result.failure = "too few features with depth";
    return result;
  }
  // The shared ORB matching (orb_features.h): ratio test, one source feature per target feature.
  std::vector<Eigen::Vector3d> matched_from, matched_to;
  for (const auto& [i, j] : match_orb(from.descriptors, to.descriptors, {options.max_hamming, options.ratio_test})) {
    matched_from.push_back(from.points[std::size_t(i)]);
    matched_to.push_back(to.points[std::size_t(j)]);
  }
  result.matches = int(matched_from.size());
  result.matched_source = matched_from;
  result.matched_target = matched_to;
  if (result.matches < options.min_inliers) {
    result.failure = "only " + std::to_string(result.matches) + " feature matches";
    return result;
  }
  // The one 3D-3D RANSAC (core/rigid_ransac.h) with one threshold for every pair, then two refits.
  const std::vector<double> thresholds(matched_from.size(), options.inlier_threshold_m);
  RigidRansacResult ransac;
  const int n = result.matches;
  // Every draw (no early stop): panorama matches can be mostly outliers, and the runner-up below
  // compares two consensus sets found with the same effort.
  const RansacBudget budget{options.ransac_iterations, 1.0, 0};
  const bool found = rigid_ransac(matched_to, matched_from, thresholds, budget, options.min_inliers, options.seed, 0,
                                  &ransac);
  if (!found) {
    result.failure =
        "RANSAC found only " + std::to_string(ransac.inliers.size()) + " consistent matches of " + std::to_string(n);
    result.inliers = int(ransac.inliers.size());
    return result;
  }
  result.target_from_source = ransac.a_from_b;
  const std::vector<int>& best_inliers = ransac.inliers;
  double sum = 0;
  for (int i : best_inliers) sum += (result.target_from_source * matched_from[i] - matched_to[i]).squaredNorm();
  result.inliers = int(best_inliers.size());
  result.inlier_rmse_m = best_inliers.empty() ? 0.0 : std::sqrt(sum / best_inliers.size());
  result.success = result.inliers >= options.min_inliers;
  if (!result.success) {
    result.failure = "too few inliers after refinement";
    return result;
  }
  // The runner-up: the same RANSAC on the matches the best pose leaves unexplained. In a room with
  // repeated or mirrored structure (the built-in office is nearly point-symmetric) the true pose
  // can be this one, with fewer matches than the mirror image.
  std::vector<Eigen::Vector3d> rest_from, rest_to;
  for (int i = 0; i < n; ++i)
    if ((result.target_from_source * matched_from[std::size_t(i)] - matched_to[std::size_t(i)]).norm() >=
        options.inlier_threshold_m) {
      rest_from.push_back(matched_from[std::size_t(i)]);
      rest_to.push_back(matched_to[std::size_t(i)]);
    }
  RigidRansacResult second;
  if (int(rest_from.size()) >= options.min_inliers &&
      rigid_ransac(rest_to, rest_from, std::vector<double>(rest_from.size(), options.inlier_threshold_m),
                   budget, options.min_inliers, options.seed, 1, &second)) {
    result.alternative_target_from_source = second.a_from_b;
    result.alternative_inliers = int(second.inliers.size());
  }
  return result;
}

int count_consistent_matches(const FeatureAlignment& features, const Rigid3d& target_from_source, double threshold_m) {
  int consistent = 0;
  for (std::size_t i = 0; i < features.matched_source.size(); ++i)
    consistent += (target_from_source * features.matched_source[i] - features.matched_target[i]).norm() < threshold_m;
  return consistent;
}

}  // namespace panoscan
