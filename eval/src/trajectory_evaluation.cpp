// `panoscan eval traj`: TUM files in, ATE / RPE report out.

#include "panoscan/eval/trajectory_evaluation.h"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/report.h"

namespace panoscan::eval {

namespace {

nlohmann::json stats_json(const ErrorStats& s, const std::string& unit) {
  return {{"count", s.count},     {"rmse_" + unit, s.rmse}, {"mean_" + unit, s.mean}, {"median_" + unit, s.median},
          {"p90_" + unit, s.p90}, {"p99_" + unit, s.p99},   {"max_" + unit, s.max}};
}

nlohmann::json positions_json(const std::vector<Eigen::Vector3d>& positions) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : positions) list.push_back({p.x(), p.y(), p.z()});
  return list;
}

}  // namespace

TrajectoryEvalOptions trajectory_eval_options_from_config(Config& config) {
  TrajectoryEvalOptions options;
  TrajectoryMetricsOptions& m = options.metrics;
  m.max_time_difference_s = config.get_double("max_time_difference_s", m.max_time_difference_s, 0.0, 1.0);
  m.rpe_delta_s = config.get_double("rpe_delta_s", m.rpe_delta_s, 1e-6, 1e6);
  m.align = config.get_bool("align", m.align);
  m.check(config.origin());
  return options;
}

TrajectoryEvalReport evaluate_trajectory_files(const std::filesystem::path& gt_path,
                                               const std::filesystem::path& est_path,
                                               const TrajectoryEvalOptions& options) {
  TrajectoryEvalReport report;
  report.gt_path = gt_path;
  report.est_path = est_path;
  report.options = options;
  const std::vector<StampedPose> gt = read_tum_trajectory(gt_path);
  if (gt.empty()) throw make_error(gt_path.string(), "", "the trajectory has no poses");
  const std::vector<StampedPose> est = read_tum_trajectory(est_path);
  if (est.empty()) throw make_error(est_path.string(), "", "the trajectory has no poses");
  report.metrics = evaluate_trajectory(gt, est, options.metrics, gt_path.string(), est_path.string());
  return report;
}

std::string trajectory_report_to_text(const TrajectoryEvalReport& r) {
  const TrajectoryMetrics& m = r.metrics;
  std::string out;
  out += fmt::format("ground truth: {} ({} poses)\nestimate:     {} ({} poses), {} matched (|dt| <= {} s)\n",
                     r.gt_path.string(), m.gt_poses, r.est_path.string(), m.est_poses, m.matched_poses,
                     r.options.metrics.max_time_difference_s);
  out += fmt::format("ATE ({}): RMSE {:.3f} mm, mean {:.3f} mm, median {:.3f} mm, max {:.3f} mm\n",
                     r.options.metrics.align ? "after rigid alignment" : "no alignment", 1e3 * m.ate_m.rmse,
                     1e3 * m.ate_m.mean, 1e3 * m.ate_m.median, 1e3 * m.ate_m.max);
  out += fmt::format("    rotation after alignment: RMSE {:.4f} deg, max {:.4f} deg\n", m.ate_rotation_deg.rmse,
                     m.ate_rotation_deg.max);
  out += fmt::format("RPE over {} s ({} pairs): translation RMSE {:.3f} mm, mean {:.3f} mm, max {:.3f} mm\n",
                     m.rpe_delta_s, m.rpe_translation_m.count, 1e3 * m.rpe_translation_m.rmse,
                     1e3 * m.rpe_translation_m.mean, 1e3 * m.rpe_translation_m.max);
  out += fmt::format("    rotation RMSE {:.4f} deg, mean {:.4f} deg, max {:.4f} deg\n", m.rpe_rotation_deg.rmse,
                     m.rpe_rotation_deg.mean, m.rpe_rotation_deg.max);
  return out;
}

std::string trajectory_report_to_json(const TrajectoryEvalReport& r) {
  const TrajectoryMetrics& m = r.metrics;
  nlohmann::json j;
  j["kind"] = "trajectory_evaluation";
  j["panoscan_version"] = project_version();
  j["source_revision"] = source_revision();
  j["inputs"] = {{"ground_truth", r.gt_path.string()},
                 {"estimate", r.est_path.string()},
                 {"gt_poses", m.gt_poses},
                 {"est_poses", m.est_poses},
                 {"matched_poses", m.matched_poses}};
  j["settings"] = {{"definition",
                    "TUM RGB-D benchmark: ATE after rigid (Horn/Umeyama, no scale) alignment; "
                    "RPE over a fixed time delta"},
                   {"max_time_difference_s", r.options.metrics.max_time_difference_s},
                   {"rpe_delta_s", r.options.metrics.rpe_delta_s},
                   {"align", r.options.metrics.align}};
  const Eigen::Matrix4d alignment = m.gt_from_est.matrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < 4; ++i) rows.push_back({alignment(i, 0), alignment(i, 1), alignment(i, 2), alignment(i, 3)});
  j["gt_from_est"] = rows;
  j["ate"] = stats_json(m.ate_m, "m");
  j["ate"]["rmse_mm"] = 1e3 * m.ate_m.rmse;
  j["ate_rotation"] = stats_json(m.ate_rotation_deg, "deg");
  j["rpe"] = {{"delta_s", m.rpe_delta_s},
              {"translation", stats_json(m.rpe_translation_m, "m")},
              {"rotation", stats_json(m.rpe_rotation_deg, "deg")}};
  j["rpe"]["translation"]["rmse_mm"] = 1e3 * m.rpe_translation_m.rmse;
  j["matched"] = {{"timestamps", m.timestamps},
                  {"gt_positions", positions_json(m.gt_positions)},
                  {"est_positions_aligned", positions_json(m.est_positions_aligned)}};
  return j.dump(2) + "\n";
}

void write_report(const std::filesystem::path& path, const std::string& text) { write_file_atomic(path, text); }

}  // namespace panoscan::eval
