// Table 4 (paper §6.3): registration between panoramas with the cost functions of the ICP family,
// on the pairs of the size preset (quick: SO-13; full: SL-12, SO-13, SO-14, SO-23, SO-24; "SO-13"
// registers SO-1 to SO-3).
//
// Panoramas come from ground-truth poses, so that the table measures stage 2 alone (with tracked
// poses each panorama carries its own tracking error, which is Table 2's subject). Every method
// starts from the same ORB + RANSAC guess and works on the same clouds (σ_z <= 0.15 m). The paper's
// figure is the RMSE against the mesh of the registered pair's cloud: the target at its true pose,
// the source placed by the estimate, every pixel of both (Table 5's "Align only" is the same
// figure for "Ours"). Beside it: the registration error of the relative pose against the truth.
// A second set of tables repeats this on panoramas from tracked poses (stage 1 as a user runs it).
#include <chrono>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "drivers.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/core/timer.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/outside_references.h"
#include "stage2_common.h"

namespace panoscan::tables {

namespace {

// Eq. 9's terms examined (issue 17, item 7): each candidate changes one term of GICP (Ours).
enum class Variant {
  kPaper,          // the paper's Eq. 9: sigma_z the measurements' spread, sigma_phi = sigma_theta = 0.5 px,
                   // Segal et al.'s surface covariance diag(eps, 1, 1)
  kStandardError,  // sigma_z / sqrt(n): the fused pixel's standard error instead of the spread
  kNoAngular,      // sigma_phi = sigma_theta = 0: the depth term alone
  kMetricSurface,  // the surface covariance scaled by the neighbourhood's spread (the default before issue 17)
};

struct Row {
  std::string name;
  IcpMethod method;
  DepthCovarianceModel covariance;  // the measured variance, the Handa model's ("Def."), or one value
  int outside;                      // 0: ours; 1: PCL's GICP; 2: Open3D's GICP
  Variant variant = Variant::kPaper;
};

constexpr auto kMeasured = DepthCovarianceModel::kMeasured;

const std::vector<Row>& rows() {
  static const std::vector<Row> r = {
      {"Point-to-point", IcpMethod::kPointToPoint, kMeasured, 0},
      {"Point-to-plane", IcpMethod::kPointToPlane, kMeasured, 0},
      {"Point-to-plane (Curv)", IcpMethod::kPointToPlaneCurvature, kMeasured, 0},
      {"GICP", IcpMethod::kGicp, kMeasured, 0},
      {"Anisotropic ICP", IcpMethod::kAnisotropic, kMeasured, 0},
      {"GICP (Def.)", IcpMethod::kGicpNoiseModel, DepthCovarianceModel::kHandaModel, 0},
      {"GICP (Ours)", IcpMethod::kGicpMeasured, kMeasured, 0},
      // Ablation (not in the paper): Ours with every pixel's sigma_z replaced by the panorama's median.
      {"GICP (Ours, constant sigma_z; ablation)", IcpMethod::kGicpMeasured, DepthCovarianceModel::kConstant, 0},
      {"PCL GICP (outside reference)", IcpMethod::kGicp, kMeasured, 1},
      {"Open3D GICP (outside reference)", IcpMethod::kGicp, kMeasured, 2},
      // Candidates (ground-truth poses only): one term of Eq. 9 changed at a time.
      {"GICP (Ours, sigma_z / sqrt(n); candidate)", IcpMethod::kGicpMeasured, kMeasured, 0, Variant::kStandardError},
      {"GICP (Ours, no angular term; candidate)", IcpMethod::kGicpMeasured, kMeasured, 0, Variant::kNoAngular},
      {"GICP (metric surface covariance; candidate)", IcpMethod::kGicp, kMeasured, 0, Variant::kMetricSurface},
      {"GICP (Ours, metric surface covariance; candidate)", IcpMethod::kGicpMeasured, kMeasured, 0,
       Variant::kMetricSurface},
  };
  return r;
}

PanoramaCloudOptions with_variant(PanoramaCloudOptions options, DepthCovarianceModel covariance, Variant variant) {
  options.covariance = covariance;
  if (variant == Variant::kStandardError) options.standard_error = true;
  if (variant == Variant::kNoAngular) options.angular_sigma_px = 0.0;
  if (variant == Variant::kMetricSurface) options.surface.metric_scale = true;
  return options;
}

const char* kTruthRow = "Ground-truth relative pose (noise floor, reference)";

// The tables of one pose source: `tracked` false = panoramas from ground-truth poses (titles
// "Table 4: ..." and "Table 4 (...)"), true = from tracked poses ("Table 4, tracked poses...").
void add_table4(const TablesOptions& options, bool tracked, TableRun& run) {
  const SizePreset preset = size_preset(options.size);
  const PairRegistrationOptions registration = stage2::registration_options(options);
  const PanoramaCloudOptions integration_cloud = stage2::integration_cloud_options(options);
  const std::string prefix = tracked ? "Table 4, tracked poses" : "Table 4";
  const std::string poses = tracked ? "tracked" : "ground-truth";
  eval::ResultTable rmse, displacement, rotation, translation, seconds;
  rmse.title = prefix + ": registration, RMSE of the registered pair's cloud against the mesh";
  rmse.decimals = 3;
  displacement.title = prefix + " (registration error): RMS displacement of the source's pixels from their true place";
  displacement.decimals = 3;
  rotation.title = prefix + " (registration error): rotation of the relative pose";
  rotation.unit = "deg";
  rotation.decimals = 4;
  translation.title = prefix + " (registration error): translation of the relative pose";
  translation.decimals = 2;
  seconds.title = prefix + " (time per registration, clouds prepared)";
  seconds.unit = "s";
  seconds.decimals = 2;

  const std::vector<std::string> pairs = pair_labels(options);
  if (pairs.empty()) throw make_error("table4", "--only", "names no pair (e.g. SO-13)");
  for (const std::string& pair : pairs) {
    const auto [source_label, target_label] = pair_scans(pair);
    const Panorama source = tracked ? stage2::tracked_panorama(source_label, options)
                                    : stage2::ground_truth_panorama(source_label, options);
    const Panorama target = tracked ? stage2::tracked_panorama(target_label, options)
                                    : stage2::ground_truth_panorama(target_label, options);
    const Rigid3d truth = target.world_from_pano.inverse() * source.world_from_pano;
    log_info(fmt::format("table4: {} ({} -> {}, {} poses)", pair, source_label, target_label, poses));

    const FeatureAlignment guess = panorama_feature_guess(source, target, registration.features);
    if (!guess.success) {
      run.notes.push_back(
          fmt::format("{} ({} poses): the ORB guess failed ({}); no registration", pair, poses, guess.failure));
      run.failures.push_back({pair, fmt::format("ORB guess failed ({} poses)", poses), guess.failure});
      continue;
    }
    // The clouds of each covariance model and variant: the same points (the filters read only the
    // measured sigma_z and the count), other covariances.
    std::map<std::pair<int, int>, std::pair<RegistrationCloud, RegistrationCloud>> clouds;
    auto clouds_for = [&](DepthCovarianceModel model, Variant variant)
        -> const std::pair<RegistrationCloud, RegistrationCloud>& {
      const std::pair<int, int> key{int(model), int(variant)};
      auto it = clouds.find(key);
      if (it == clouds.end()) {
        const PanoramaCloudOptions cloud_options = with_variant(registration.cloud, model, variant);
        it = clouds
                 .emplace(key, std::make_pair(panorama_registration_cloud(source, cloud_options),
                                              panorama_registration_cloud(target, cloud_options)))
                 .first;
      }
      return it->second;
    };
    const RegistrationCloud& source_measured = clouds_for(kMeasured, Variant::kPaper).first;
    const RegistrationCloud& target_measured = clouds_for(kMeasured, Variant::kPaper).second;

    // The pair's cloud: every usable pixel of both; the target's part does not change with the method.
    const auto mesh = stage2::scene_mesh(source_label, options);
    const std::vector<Eigen::Vector3d> source_points =
        panorama_integration_points(source, Rigid3d::Identity(), integration_cloud).points;
    std::vector<Eigen::Vector3d> target_points =
        panorama_integration_points(target, Rigid3d::Identity(), integration_cloud).points;
    for (auto& p : target_points) p = target.world_from_pano * p;
    const std::vector<double> target_distances = mesh->distances(target_points, target_label);
    auto pair_rmse_mm = [&](const Rigid3d& target_from_source) {
      const Rigid3d world_from_source = target.world_from_pano * target_from_source;
      std::vector<Eigen::Vector3d> placed(source_points.size());
      for (std::size_t i = 0; i < placed.size(); ++i) placed[i] = world_from_source * source_points[i];
      std::vector<double> d = mesh->distances(placed, source_label);
      d.insert(d.end(), target_distances.begin(), target_distances.end());
      return stage2::distance_stats(std::move(d)).rmse_mm;
    };
    // One figure for the pose error where it matters: how far the source's pixels land from where
    // the true pose puts them (rotation errors weigh by the pixels' distance).
    auto displacement_mm = [&](const Rigid3d& target_from_source) {
      std::vector<double> displacement;
      displacement.reserve(source_points.size());
      for (const Eigen::Vector3d& p : source_points)
        displacement.push_back((target_from_source * p - truth * p).norm());
      return eval::summarize_errors(std::move(displacement)).rmse * 1e3;
    };

    for (const Row& row : rows()) {
      if (tracked && row.variant != Variant::kPaper) continue;
      IcpOptions icp = registration.icp;
      icp.method = row.method;
      const auto& [s, t] = clouds_for(row.covariance, row.variant);
      IcpResult result;
      const auto start = std::chrono::steady_clock::now();
      try {
        result = row.outside == 1   ? register_pcl_gicp(s, t, guess.target_from_source, icp)
                 : row.outside == 2 ? register_open3d_gicp(s, t, guess.target_from_source, icp)
                                    : register_icp(s, t, guess.target_from_source, icp);
      } catch (const Error& e) {
        run.notes.push_back(fmt::format("{} {} ({} poses): failed: {}", pair, row.name, poses, e.what()));
        run.failures.push_back({pair, fmt::format("{} failed ({} poses)", row.name, poses), e.what()});
        continue;
      }
      const double elapsed = seconds_since(start);
      const Rigid3d& estimate = result.target_from_source;
      rmse.set(row.name, pair, pair_rmse_mm(estimate));
      displacement.set(row.name, pair, displacement_mm(estimate));
      rotation.set(row.name, pair, rad2deg(rotation_angle(truth.linear().transpose() * estimate.linear())));
      translation.set(row.name, pair, (estimate.translation() - truth.translation()).norm() * 1e3);
      seconds.set(row.name, pair, elapsed);
      const int consistent = count_consistent_matches(guess, estimate, registration.consistency_threshold_m);
      if (consistent < registration.min_consistent_fraction * guess.inliers)
        run.notes.push_back(
            fmt::format("{} {} ({} poses): the pose explains only {} of {} ORB inliers (a wrong "
                        "registration)",
                        pair, row.name, poses, consistent, guess.inliers));
      log_info(fmt::format("table4: {} {}: {:.1f} s, {} iterations", pair, row.name, elapsed, result.iterations));
    }
    rmse.set(tracked ? "First-frame-aligned relative pose (reference)" : kTruthRow, pair, pair_rmse_mm(truth));
    displacement.set("ORB + RANSAC initial guess", pair, displacement_mm(guess.target_from_source));
    rotation.set("ORB + RANSAC initial guess", pair,
                 rad2deg(rotation_angle(truth.linear().transpose() * guess.target_from_source.linear())));
    translation.set("ORB + RANSAC initial guess", pair,
                    (guess.target_from_source.translation() - truth.translation()).norm() * 1e3);
    run.notes.push_back(
        fmt::format("{} ({} poses): {} and {} registration points, {} and {} pixels in the pair's "
                    "cloud; ORB guess from {} inliers",
                    pair, poses, source_measured.points.size(), target_measured.points.size(), source_points.size(),
                    target_points.size(), guess.inliers));
  }
  if (tracked) {
    // The pose errors need a true relative pose, which tracked panoramas do not have (each carries
    // its own tracking error): only the cloud's RMSE and the times.
    run.tables.push_back(rmse);
    run.tables.push_back(seconds);
    run.notes.push_back(
        "Tracked poses: each panorama tracked by the paper's graph (`recon track`'s defaults without the depth odometry), placed in the scene frame by aligning the tracked "
        "reference camera's first frame with the truth; the target's place in the pair's cloud comes from that "
        "alignment, so the table carries the panoramas' own tracking error (as the paper's "
        "Table 4 does). The reference row places the source by that alignment too (both scans' first frames "
        "aligned with the truth).");
    return;
  }
  for (eval::ResultTable* t : {&rmse, &displacement, &rotation, &translation, &seconds}) run.tables.push_back(*t);
  run.notes.push_back(fmt::format(
      "Panoramas from ground-truth poses (TSA, H = {}): the first tables isolate stage 2 (registration) from the "
      "tracking error of stage 1.",
      preset.panorama_height));
  run.notes.push_back(fmt::format(
      "Registration on every {}-th pixel row and column (the same point count at every size), lambda_a = {} m, at most "
      "{} iterations, pixels with sigma_z > {} m or fewer than {} observations dropped; all methods from the same ORB "
      "+ RANSAC guess. RMSE over every usable pixel of both panoramas (no cut-off).",
      registration.cloud.pixel_stride, registration.icp.max_correspondence_m, registration.icp.max_iterations,
      registration.cloud.max_sigma_m, registration.cloud.min_observations));
  run.notes.push_back(
      "PCL's and Open3D's GICP compute their own covariances from the same points (no measured "
      "variance); PCL is single-threaded. Times include no cloud preparation.");
  nlohmann::json settings = {{"poses", "ground-truth, then tracked"},
                             {"registration_pixel_stride", registration.cloud.pixel_stride},
                             {"max_correspondence_m", registration.icp.max_correspondence_m},
                             {"max_iterations", registration.icp.max_iterations},
                             {"max_sigma_m", registration.cloud.max_sigma_m},
                             {"min_observations", registration.cloud.min_observations},
                             {"pairs", pairs}};
  run.settings_json = settings.dump();
}

TableRun run_table4(const TablesOptions& options) {
  TableRun run;
  add_table4(options, false, run);
  add_table4(options, true, run);
  run.claims = {
      {"Table 4:", "GICP (Ours)", "GICP", "the measured variance improves GICP (cloud RMSE)"},
      {"Table 4:", "GICP (Ours)", "GICP (Def.)", "the measured variance beats the Handa model's (cloud RMSE)"},
      {"Table 4:", "GICP (Ours)", "Point-to-plane", "GICP (Ours) beats point-to-plane ICP (cloud RMSE)"},
      {"Table 4 (registration error): RMS displacement", "GICP (Ours)", "GICP", "the same on the source's pixel displacement"},
      {"Table 4 (registration error): RMS displacement", "GICP (Ours)", "GICP (Ours, constant sigma_z; ablation)",
       "the per-pixel variance beats one constant sigma_z (ablation; pixel displacement)"},
  };
  return run;
}

}  // namespace

TableRun run_table4_ground_truth_poses(const TablesOptions& options) {
  TableRun run;
  run.name = "table4";
  add_table4(options, false, run);
  return run;
}

TableDriver table4_driver() {
  return {"table4", "registration cost functions (paper Table 4): RMSE of the registered pair, pose errors",
          run_table4, pair_columns};
}

}  // namespace panoscan::tables
