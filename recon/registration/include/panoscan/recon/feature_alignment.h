// Initial guess for registering two panoramas (paper §5.1): ORB matches between the two colour
// panoramas (the shared ORB module, panoscan/recon/orb_features.h: the same detection and matching
// as the tracking front end), back-projected to 3D with their radial depths, and a rigid RANSAC on
// the 3D pairs (core's rigid_ransac).
// A hypothesis is judged by its evidence: the RANSAC inliers among those matches plus the matches
// a search guided by the hypothesis adds (each source feature against the target features within
// inlier_threshold_m of where the pose puts it; match_orb_among's rules with guided_max_hamming).
// In a plain room the ratio test over a whole panorama leaves few true matches (walls and similar
// corners make descriptors ambiguous at the scale of the room, not within 5 cm), so the count of
// inliers alone refused right guesses.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"

namespace panoscan {

// An equirectangular RGB-D panorama as images: colour (3 channels) and radial depth (metres,
// 0 = none), both H x 2H.
struct PanoramaImages {
  const ImageU8* rgb = nullptr;
  const ImageF32* radial_depth = nullptr;
};

struct FeatureAlignmentOptions {
  int max_features = 8000;           // ORB features per panorama
  double ratio_test = 0.8;           // Lowe's ratio on Hamming distances (orb_features.h's rule)
  int max_hamming = 256;             // descriptor distance limit (of 256 bits; 256 = none)
  double inlier_threshold_m = 0.05;  // RANSAC: 3D distance after the transform
  int ransac_iterations = 4000;
  int min_inliers = 25;         // evidence (inliers + guided matches) below this: the alignment failed
  int guided_max_hamming = 64;  // guided matches: descriptor distance limit (the front end's)
  std::uint64_t seed = 1;  // RANSAC sampling (deterministic)

  void check() const;
};

struct FeatureAlignment {
  bool success = false;
  std::string failure;  // why not, when !success
  Rigid3d target_from_source = Rigid3d::Identity();
  int source_features = 0, target_features = 0;
  int matches = 0;  // after ratio and cross check, with valid depth on both sides
  int inliers = 0;  // RANSAC's consensus among `matches`
  int guided_matches = 0;  // matches the guided search adds at the pose (not among `matches`' sources)
  int evidence() const { return inliers + guided_matches; }
  double inlier_rmse_m = 0.0;
  // The best pose among the matches the best one leaves unexplained (the same RANSAC on them), when
  // its evidence reaches min_inliers: in a room with repeated or mirrored structure a distinct pose
  // can explain many matches too, and the true one may be this runner-up (stage2.h's ambiguity check).
  Rigid3d alternative_target_from_source = Rigid3d::Identity();
  int alternative_inliers = 0;  // 0: no runner-up
  int alternative_guided_matches = 0;
  int alternative_evidence() const { return alternative_inliers + alternative_guided_matches; }
  // The matched 3D points (panorama frames) after the ratio and cross checks, then the guided
  // matches of the pose and of the runner-up, for verifying a pose found otherwise
  // (count_consistent_matches). The first `matches` are the ratio-test matches.
  std::vector<Eigen::Vector3d> matched_source, matched_target;
};

// Two poses of one pair are one hypothesis (one basin of GICP) when they differ by at most 2 degrees
// and 10 cm, the loop-closure tolerances of placement.h: the runner-up must be farther from the best
// pose to be a runner-up, and the ambiguity check (stage2.h) calls two refined poses distinct beyond.
bool same_registration_basin(const Rigid3d& a, const Rigid3d& b);

// How many of the feature matches a pose explains within `threshold_m`.
int count_consistent_matches(const FeatureAlignment& features, const Rigid3d& target_from_source, double threshold_m);

// A panorama's ORB features with depth: detected once, matched against every neighbour.
struct PanoramaFeatures {
  std::vector<Eigen::Vector3d> points;                    // back-projected keypoints (panorama frame)
  std::vector<std::array<std::uint8_t, 32>> descriptors;  // ORB, aligned with points
};

// Throws Error (naming `role`) when the images are missing or not H x 2H of one size.
PanoramaFeatures detect_panorama_features(const PanoramaImages& images, const FeatureAlignmentOptions& options,
                                          const char* role = "panorama");

FeatureAlignment align_panorama_features(const PanoramaFeatures& source, const PanoramaFeatures& target,
                                         const FeatureAlignmentOptions& options);
// Detects both, then aligns.
FeatureAlignment align_panorama_features(const PanoramaImages& source, const PanoramaImages& target,
                                         const FeatureAlignmentOptions& options);

}  // namespace panoscan
