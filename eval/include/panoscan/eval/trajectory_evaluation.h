// `panoscan eval traj`: an estimated TUM trajectory against its ground truth, as text and JSON.
#pragma once

#include <filesystem>
#include <string>

#include "panoscan/eval/trajectory_metrics.h"

namespace panoscan {
class Config;
}

namespace panoscan::eval {

struct TrajectoryEvalOptions {
  TrajectoryMetricsOptions metrics;
};

// Keys: max_time_difference_s (1e-4), rpe_delta_s (1.0), align (true).
TrajectoryEvalOptions trajectory_eval_options_from_config(Config& config);

struct TrajectoryEvalReport {
  std::filesystem::path gt_path, est_path;
  TrajectoryEvalOptions options;
  TrajectoryMetrics metrics;
};

// Reads both files (read_tum_trajectory) and evaluates. Throws Error naming the file(s) for bad
// input: missing/corrupt files, no common timestamps, too few matched poses, a trajectory shorter
// than the RPE delta.
TrajectoryEvalReport evaluate_trajectory_files(const std::filesystem::path& gt_path,
                                               const std::filesystem::path& est_path,
                                               const TrajectoryEvalOptions& options = {});

std::string trajectory_report_to_text(const TrajectoryEvalReport& report);  // mm and degrees
std::string trajectory_report_to_json(const TrajectoryEvalReport& report);  // with matched positions

// Writes a report string (JSON, Markdown...) atomically.
void write_report(const std::filesystem::path& path, const std::string& text);

}  // namespace panoscan::eval
