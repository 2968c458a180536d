#include "panoscan/recon/feature_alignment.h"

#include <algorithm>
#include <cmath>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"
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
  if (guided_max_hamming < 0 || guided_max_hamming > 256)
    throw make_error("", "registration.features.guided_max_hamming", "must be in [0, 256] (0: no guided search)");
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

namespace {

// The matches a search guided by `target_from_source` adds to a consensus: each source feature
// against the (up to 8 nearest) target features within options.inlier_threshold_m of where the pose
// puts it, by match_orb_among's rules (the ratio test among those candidates, one source per
// target) with options.guided_max_hamming: within 5 cm a plain wall's corners are no longer
// alike, so matches the whole-panorama ratio test had to drop come back.
// Sources and targets already in `consensus` (pairs of indices into from / to) are left out, so the
// evidence counts each feature once. Appends the added pairs to `added`.
void guided_matches(const PanoramaFeatures& from, const PanoramaFeatures& to, const PointKdTree& to_tree,
                    const Rigid3d& target_from_source, const std::vector<std::pair<int, int>>& consensus,
                    const FeatureAlignmentOptions& options, std::vector<std::pair<int, int>>* added) {
  if (options.guided_max_hamming <= 0) return;
  std::vector<char> source_used(from.points.size(), 0), target_used(to.points.size(), 0);
  for (const auto& [i, j] : consensus) source_used[std::size_t(i)] = target_used[std::size_t(j)] = 1;
  constexpr std::size_t kCandidates = 8;  // nearest target features within the radius
  std::uint32_t nearest[kCandidates];
  double squared[kCandidates];
  std::vector<int> offsets{0}, candidates;
  offsets.reserve(from.points.size() + 1);
  for (std::size_t i = 0; i < from.points.size(); ++i) {
    if (!source_used[i]) {
      const std::size_t found = to_tree.knn_within(target_from_source * from.points[i], kCandidates,
                                                   options.inlier_threshold_m, nearest, squared);
      for (std::size_t k = 0; k < found; ++k)
        if (!target_used[nearest[k]]) candidates.push_back(int(nearest[k]));
    }
    offsets.push_back(int(candidates.size()));
  }
  for (const auto& pair : match_orb_among(from.descriptors, to.descriptors, offsets, candidates,
                                          {options.guided_max_hamming, options.ratio_test}))
    added->push_back(pair);
}

}  // namespace

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
  const std::vector<std::pair<int, int>> matches =
      match_orb(from.descriptors, to.descriptors, {options.max_hamming, options.ratio_test});
  std::vector<Eigen::Vector3d> matched_from, matched_to;
  for (const auto& [i, j] : matches) {
    matched_from.push_back(from.points[std::size_t(i)]);
    matched_to.push_back(to.points[std::size_t(j)]);
  }
  result.matches = int(matched_from.size());
  result.matched_source = matched_from;
  result.matched_target = matched_to;
  if (result.matches < 3) {
    result.failure = "only " + std::to_string(result.matches) + " feature matches";
    return result;
  }
  const PointKdTree to_tree(to.points);
  // A RANSAC consensus (indices into `matches`) and its guided matches; appends the latter to the
  // result's matched points. Returns the evidence.
  auto add_guided = [&](const Rigid3d& target_from_source, const std::vector<int>& inliers, int* guided_count) {
    std::vector<std::pair<int, int>> consensus, added;
    for (int k : inliers) consensus.push_back(matches[std::size_t(k)]);
    guided_matches(from, to, to_tree, target_from_source, consensus, options, &added);
    for (const auto& [i, j] : added) {
      result.matched_source.push_back(from.points[std::size_t(i)]);
      result.matched_target.push_back(to.points[std::size_t(j)]);
    }
    *guided_count = int(added.size());
    return int(inliers.size()) + *guided_count;
  };
  // The one 3D-3D RANSAC (core/rigid_ransac.h) with one threshold for every pair, then two refits.
  // Its consensus is not held to min_inliers here: the evidence (with the guided matches) is.
  const std::vector<double> thresholds(matched_from.size(), options.inlier_threshold_m);
  RigidRansacResult ransac;
  const int n = result.matches;
  // Every draw (no early stop): panorama matches can be mostly outliers, and the runner-up below
  // compares two consensus sets found with the same effort.
  const RansacBudget budget{options.ransac_iterations, 1.0, 0};
  if (!rigid_ransac(matched_to, matched_from, thresholds, budget, 3, options.seed, 0, &ransac)) {
    result.failure = "RANSAC found no pose consistent with 3 of the " + std::to_string(n) + " feature matches";
    return result;
  }
  result.target_from_source = ransac.a_from_b;
  const std::vector<int>& best_inliers = ransac.inliers;
  double sum = 0;
  for (int i : best_inliers) sum += (result.target_from_source * matched_from[i] - matched_to[i]).squaredNorm();
  result.inliers = int(best_inliers.size());
  result.inlier_rmse_m = best_inliers.empty() ? 0.0 : std::sqrt(sum / best_inliers.size());
  const int evidence = add_guided(result.target_from_source, best_inliers, &result.guided_matches);
  result.success = evidence >= options.min_inliers;
  if (!result.success) {
    result.failure = "the best pose is consistent with only " + std::to_string(result.inliers) + " of " +
                     std::to_string(n) + " feature matches, and a search at it adds " +
                     std::to_string(result.guided_matches) + " (features.min_inliers " +
                     std::to_string(options.min_inliers) + ")";
    return result;
  }
  // The runner-up: the same RANSAC on the matches the best pose leaves unexplained. In a room with
  // repeated or mirrored structure (the built-in office is nearly point-symmetric) the true pose
  // can be this one, with fewer matches than the mirror image.
  std::vector<Eigen::Vector3d> rest_from, rest_to;
  std::vector<int> rest_index;
  for (int i = 0; i < n; ++i)
    if ((result.target_from_source * matched_from[std::size_t(i)] - matched_to[std::size_t(i)]).norm() >=
        options.inlier_threshold_m) {
      rest_from.push_back(matched_from[std::size_t(i)]);
      rest_to.push_back(matched_to[std::size_t(i)]);
      rest_index.push_back(i);
    }
  // A runner-up in the best pose's basin (matches just outside the threshold agreeing on a nearly
  // equal pose) is the same hypothesis: refining it would be a second GICP for nothing.
  RigidRansacResult second;
  if (rest_from.size() >= 3 &&
      rigid_ransac(rest_to, rest_from, std::vector<double>(rest_from.size(), options.inlier_threshold_m), budget, 3,
                   options.seed, 1, &second) &&
      !same_registration_basin(second.a_from_b, result.target_from_source)) {
    std::vector<int> second_inliers;
    for (int k : second.inliers) second_inliers.push_back(rest_index[std::size_t(k)]);
    const std::size_t matched_before = result.matched_source.size();
    int second_guided = 0;
    if (add_guided(second.a_from_b, second_inliers, &second_guided) >= options.min_inliers) {
      result.alternative_target_from_source = second.a_from_b;
      result.alternative_inliers = int(second.inliers.size());
      result.alternative_guided_matches = second_guided;
    } else {
      // Not a runner-up: its guided matches are no evidence for anything.
      result.matched_source.resize(matched_before);
      result.matched_target.resize(matched_before);
    }
  }
  return result;
}

bool same_registration_basin(const Rigid3d& a, const Rigid3d& b) {
  const Rigid3d between = a.inverse() * b;
  return rad2deg(rotation_angle(between.linear())) <= 2.0 && between.translation().norm() <= 0.1;
}

int count_consistent_matches(const FeatureAlignment& features, const Rigid3d& target_from_source, double threshold_m) {
  int consistent = 0;
  for (std::size_t i = 0; i < features.matched_source.size(); ++i)
    consistent += (target_from_source * features.matched_source[i] - features.matched_target[i]).norm() < threshold_m;
  return consistent;
}

}  // namespace panoscan
