// Stage 2 of the method (paper §5) on built panoramas: registration between panoramas and their
// integration into one scene cloud.
//
// A panorama pixel becomes a point P^A = D * direction(pixel) (panorama frame) with the measurement
// covariance of Eq. 9, J diag(sigma_phi^2, sigma_theta^2, sigma_z^2) J^T, sigma_phi = sigma_theta =
// 0.5 pi / H, where sigma_z is the pixel's measured std ("measured", the paper's) or the Handa
// model's at that depth ("handa-model", Table 4's "Def."), or one value for every pixel ("constant",
// an ablation: the measured variance without its per-pixel information). Pixels with sigma_z > 0.15 m
// are dropped first (§6.3), and so are pixels seen fewer than min_observations times.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "panoscan/core/config.h"

#include "panoscan/recon/feature_alignment.h"
#include "panoscan/recon/integration.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/pose_graph.h"
#include "panoscan/recon/registration.h"

namespace panoscan {

enum class DepthCovarianceModel { kMeasured, kHandaModel, kConstant };

const char* to_string(DepthCovarianceModel model);  // measured, handa-model, constant

struct PanoramaCloudOptions {
  DepthCovarianceModel covariance = DepthCovarianceModel::kMeasured;
  double max_sigma_m = 0.15;  // drop pixels whose measured sigma_z exceeds this (§6.3)
  int min_observations = 2;   // a variance needs at least two measurements
  int pixel_stride = 1;       // use every n-th row and column (speed; 1 = all pixels)
  // kConstant: every pixel's sigma_z; 0 = the median measured sigma_z of the usable pixels (the same
  // overall scale as the measured variance, no per-pixel information).
  double constant_sigma_m = 0.0;
  // Eq. 9's S-frame measurement covariance diag(sigma_phi^2, sigma_theta^2, sigma_z^2) (issue 17,
  // item 7 examines each term; the defaults are the paper's):
  // sigma_phi = sigma_theta = angular_sigma_px * pi / H (the paper: 0.5 pixel, "rasterization").
  double angular_sigma_px = 0.5;
  // kMeasured: sigma_z is the spread of the pixel's measurements about the solved depth (the
  // paper's §4 "variance of the radial distance"); true = that spread / sqrt(count), the standard
  // error of a mean of `count` independent measurements (what the fused depth's own error would be).
  bool standard_error = false;
  SurfaceOptions surface;
};

// Points, measurement covariances, confidences (counts) and surfaces of a panorama, in its own
// frame; `pixels` receives the pixel index of each point when given.
RegistrationCloud panorama_registration_cloud(const Panorama& panorama, const PanoramaCloudOptions& options,
                                              std::vector<std::size_t>* pixels = nullptr);

struct PairRegistrationOptions {
  IcpOptions icp;
  FeatureAlignmentOptions features;
  PanoramaCloudOptions cloud;
  // The final pose must explain at least this fraction of the RANSAC inliers of the feature
  // guess; otherwise the registration is reported as failed (an Error).
  double min_consistent_fraction = 0.5;
  double consistency_threshold_m = 0.05;
  // At the final pose at least this fraction of the source points must have a target point within
  // icp.max_correspondence_m whose plane lies within icp.fitness_distance_m (surface_overlap); below
  // it the panoramas do not overlap there (an Error). A plane distance, so that the figure does not
  // depend on the sampling density. A wrong pose in the same room is caught by the feature check.
  double min_fitness = 0.5;
  // Ambiguity (registration.ambiguity_margin): when the ORB guess has a runner-up (a distinct pose
  // from the matches the best leaves unexplained; feature_alignment.h), ICP refines it too. If it
  // converges to a distinct pose whose overlap is within this margin of the best's, the registration
  // refuses (an Error asking for an initial pose); if it is better by more, it is taken. The margin is
  // wide because the overlap favours the shorter baseline: the mirrored pose of a point-symmetric pair
  // puts both centres in one place, where nothing is occluded (measured on the office's SO-2 -> SO-1:
  // 0.90 at the mirror against 0.79 at the truth on noiseless renders, 0.87 against 0.88 on simulated
  // scans), while a spurious runner-up in an asymmetric room lies far below (living room SL-1 -> SL-2:
  // 0.62 against 0.96).
  double ambiguity_margin = 0.15;
  // Within the margin the geometry cannot choose; the appearance can when it is one-sided. A runner-up
  // whose feature evidence (RANSAC inliers + guided matches) is below this fraction of the best's, while
  // the best also overlaps at least as well, is dismissed rather than called a rival: both cues agree.
  // A symmetric room's rivals share the evidence (the office's mirror pairs: 0.33 of the best's on
  // noiseless renders at H = 512, 0.62-0.82 on simulated scans at H = 1024); a chance runner-up from the
  // matches the best leaves unexplained holds 0.05-0.08, and made the whole office's chain refuse on some
  // seeds (recon/registration/README.md, "Ambiguity"). 0.15 lies between, about equally far from both
  // in ratio. registration.ambiguity_evidence_fraction; 0: never dismiss.
  double ambiguity_evidence_fraction = 0.15;
};

// The ORB + RANSAC guess between the two colour panoramas (§5.1), as register_panorama_pair makes it.
FeatureAlignment panorama_feature_guess(const Panorama& source, const Panorama& target,
                                        const FeatureAlignmentOptions& options);

struct PairRegistration {
  Rigid3d target_from_source = Rigid3d::Identity();
  FeatureAlignment guess;  // the ORB guess (also when an initial pose was given: used to verify)
  IcpResult icp;
  int consistent_matches = 0;
  double overlap = 0.0;  // surface_overlap at the final pose
  // The runner-up of the ORB guess after ICP (alternative_refined: there was one, no initial pose was
  // given, and its ICP converged), its overlap and the feature matches it explains.
  bool alternative_refined = false;
  Rigid3d alternative_target_from_source = Rigid3d::Identity();
  double alternative_overlap = 0.0;
  int alternative_consistent_matches = 0;
  // The refined runner-up fit about as well as the result but held too little of the feature evidence
  // to be a rival (PairRegistrationOptions::ambiguity_evidence_fraction): the result was kept.
  bool alternative_dismissed = false;
};

// What the ambiguity check (PairRegistrationOptions::ambiguity_margin, ambiguity_evidence_fraction)
// makes of a refined runner-up distinct from the best pose, from the two overlaps and feature
// evidences: keep the best (the runner-up overlaps clearly less), take the runner-up (clearly more),
// keep the best with the runner-up dismissed (about as much, but the best overlaps at least as well
// and the runner-up holds less than ambiguity_evidence_fraction of the best's evidence), or refuse as
// ambiguous (about as much otherwise).
enum class RunnerUpVerdict { kKeepBest, kTakeRunnerUp, kDismissed, kAmbiguous };
RunnerUpVerdict judge_runner_up(double best_overlap, int best_evidence, double runner_up_overlap,
                                int runner_up_evidence, const PairRegistrationOptions& options);

// The refined runner-up of a registration as JSON (`recon register`'s "alternative", `recon scene`'s
// "runner_up"): its ORB inliers, guided matches and evidence, whether it was dismissed, its pose,
// overlap and consistent matches, and how far it lies from the result. Null when none was refined.
nlohmann::json runner_up_to_json(const PairRegistration& registration);

// The fraction of source points whose nearest target point (within max_correspondence_m, after
// target_from_source) has its tangent plane within max_plane_distance_m. Needs target normals.
double surface_overlap(const RegistrationCloud& source, const RegistrationCloud& target,
                       const Rigid3d& target_from_source, double max_correspondence_m, double max_plane_distance_m);

// Registers `source` onto `target`: the initial pose is `given_initial` if not null, else the ORB
// guess; then ICP with options.icp; then the result is checked against the feature matches.
// Throws Error (naming the two panoramas by `source_name` / `target_name`) when the panoramas
// differ in size, when one has too few usable pixels, when the ORB guess fails and no initial pose
// is given, when the panoramas do not overlap at the pose (fewer than options.min_fitness of
// the source points close to the target), or when the final pose contradicts the features.
PairRegistration register_panorama_pair(const Panorama& source, const Panorama& target,
                                        const PairRegistrationOptions& options, const Rigid3d* given_initial,
                                        const std::string& source_name, const std::string& target_name);

// What registration needs of one panorama, prepared once for all the pairs it is in (recon scene
// registers each panorama with up to n - 1 others): its registration cloud with surfaces and its
// ORB features. Throws Error naming `name` when the panorama has too few usable pixels.
struct PreparedPanorama {
  std::string name;
  int height = 0;  // H of the panorama
  RegistrationCloud cloud;
  PanoramaFeatures features;
};
PreparedPanorama prepare_panorama_for_registration(const Panorama& panorama, const PairRegistrationOptions& options,
                                                   const std::string& name);
// The same as above on prepared panoramas (identical results).
PairRegistration register_panorama_pair(const PreparedPanorama& source, const PreparedPanorama& target,
                                        const PairRegistrationOptions& options, const Rigid3d* given_initial);

// The panorama's points for integration (scene frame from `world_from_panorama`), with Eq. 9's
// covariance (surface + measurement) and colours.
PanoramaPoints panorama_integration_points(const Panorama& panorama, const Rigid3d& world_from_panorama,
                                           const PanoramaCloudOptions& options);

// Keys registration.{method (gicp-ours), max_correspondence_m (0.15), max_iterations (50),
// min_fitness (0.5; PairRegistrationOptions::min_fitness), covariance (measured | handa-model | constant; handa-model
// for gicp-def), constant_sigma_m (0 = median measured), pixel_stride (1), min_observations (2), max_sigma_m (0.15)},
// seed (RANSAC), threads.
PairRegistrationOptions pair_registration_options_from_config(Config& config);
// Keys integration.{method (map | average | align), weighting (information | paper-inverse-sqrt)}, threads.
IntegrationOptions integration_options_from_config(Config& config);

}  // namespace panoscan
