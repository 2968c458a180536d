// TUM trajectory files ("timestamp tx ty tz qx qy qz qw", world_from_camera per line).
//
// The reader is strict because a silently skipped or reordered pose would corrupt every error
// metric computed from it: each non-comment line must hold exactly 8 finite numbers, the
// quaternion must be normalisable, and timestamps must strictly increase. The writer refuses
// poses the reader would reject, so every file we write can be read back.

#include "panoscan/core/trajectory.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"

namespace panoscan {
namespace {

// Quaternions shorter than this cannot be normalised meaningfully (a line of zeros, typically).
constexpr double kMinQuaternionNorm = 1e-6;

bool parse_finite_double(const std::string& token, double* value) {
  errno = 0;
  char* end = nullptr;
  const double parsed = std::strtod(token.c_str(), &end);
  if (token.empty() || end != token.c_str() + token.size() || errno == ERANGE || !std::isfinite(parsed)) return false;
  *value = parsed;
  return true;
}

std::string line_field(std::size_t line_number) { return "line " + std::to_string(line_number); }

std::string format_fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

}  // namespace

std::string format_timestamp(double timestamp) { return format_fixed(timestamp, 6); }

std::vector<StampedPose> read_tum_trajectory(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw make_error(file, "", "trajectory file not found");
  std::ifstream in(path);
  if (!in) throw make_error(file, "", "cannot open trajectory file for reading");

  std::vector<StampedPose> poses;
  std::string line;
  std::size_t line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // files written on Windows
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;

    std::istringstream tokens(line);
    std::vector<std::string> fields;
    std::string token;
    while (tokens >> token) fields.push_back(token);
    if (fields.size() != 8) {
      throw make_error(
          file, line_field(line_number),
          "expected 8 numbers (timestamp tx ty tz qx qy qz qw), found " + std::to_string(fields.size()) + " fields");
    }
    double numbers[8];
    for (int i = 0; i < 8; ++i) {
      if (!parse_finite_double(fields[i], &numbers[i])) {
        throw make_error(file, line_field(line_number),
                         "field " + std::to_string(i + 1) + " is not a finite number: '" + fields[i] + "'");
      }
    }
    // Eigen's Quaterniond constructor takes (w, x, y, z); the file holds x y z w.
    Eigen::Quaterniond rotation(numbers[7], numbers[4], numbers[5], numbers[6]);
    const double norm = rotation.norm();
    if (norm < kMinQuaternionNorm) {
      throw make_error(file, line_field(line_number), "quaternion (qx qy qz qw) has zero length");
    }
    rotation.coeffs() /= norm;

    StampedPose pose;
    pose.timestamp = numbers[0];
    pose.world_from_cam = make_rigid(rotation, Eigen::Vector3d(numbers[1], numbers[2], numbers[3]));
    if (!poses.empty() && !(pose.timestamp > poses.back().timestamp)) {
      const char* problem = pose.timestamp == poses.back().timestamp ? "repeats" : "is before";
      throw make_error(file, line_field(line_number),
                       "timestamp " + fields[0] + " " + problem + " the previous one (" +
                           format_timestamp(poses.back().timestamp) + "); timestamps must strictly increase");
    }
    poses.push_back(pose);
  }
  if (in.bad()) throw make_error(file, "", "error while reading trajectory file");
  return poses;
}

std::vector<std::optional<Rigid3d>> interpolate_trajectory(const std::vector<StampedPose>& poses,
                                                           const std::vector<double>& times, double max_dt) {
  if (!std::isfinite(max_dt) || max_dt < 0.0) {
    throw make_error("", "max_dt", "expected a finite number of seconds >= 0, found " + std::to_string(max_dt));
  }
  for (std::size_t i = 1; i < poses.size(); ++i) {
    if (!(poses[i - 1].timestamp < poses[i].timestamp)) {
      throw make_error("", "pose " + std::to_string(i), "trajectory timestamps must strictly increase");
    }
  }
  std::vector<std::optional<Rigid3d>> result(times.size());
  for (std::size_t q = 0; q < times.size(); ++q) {
    const double t = times[q];
    if (!std::isfinite(t)) continue;
    const auto after = std::lower_bound(poses.begin(), poses.end(), t,
                                        [](const StampedPose& pose, double time) { return pose.timestamp < time; });
    if (after != poses.end() && after->timestamp == t) {
      result[q] = after->world_from_cam;
      continue;
    }
    if (after == poses.begin() || after == poses.end()) continue;
    const StampedPose& a = *(after - 1);
    const StampedPose& b = *after;
    if (t - a.timestamp > max_dt || b.timestamp - t > max_dt) continue;
    const double s = (t - a.timestamp) / (b.timestamp - a.timestamp);
    const Eigen::Quaterniond qa(a.world_from_cam.linear());
    const Eigen::Quaterniond qb(b.world_from_cam.linear());
    const Eigen::Vector3d translation =
        (1.0 - s) * a.world_from_cam.translation() + s * b.world_from_cam.translation();
    result[q] = make_rigid(qa.slerp(s, qb).normalized(), translation);
  }
  return result;
}

void write_tum_trajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses) {
  const std::string file = path.string();
  std::string text = "# timestamp tx ty tz qx qy qz qw (world_from_camera)\n";
  double previous_written_timestamp = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const StampedPose& pose = poses[i];
    const std::string field = "pose " + std::to_string(i);
    const Eigen::Vector3d translation = pose.world_from_cam.translation();
    const Eigen::Matrix3d rotation_matrix = pose.world_from_cam.linear();
    if (!std::isfinite(pose.timestamp) || !translation.allFinite() || !rotation_matrix.allFinite()) {
      throw make_error(file, field, "cannot write a non-finite pose or timestamp");
    }
    // Compare the timestamps as they will be read back (6 decimals), so that two poses 1e-7 s
    // apart cannot produce a file with a repeated timestamp.
    const std::string timestamp_text = format_timestamp(pose.timestamp);
    const double written_timestamp = std::strtod(timestamp_text.c_str(), nullptr);
    if (i > 0 && !(written_timestamp > previous_written_timestamp)) {
      throw make_error(file, field,
                       "timestamp " + timestamp_text + " does not increase (previous " +
                           format_timestamp(previous_written_timestamp) + ", kept to 6 decimals)");
    }
    previous_written_timestamp = written_timestamp;

    const Eigen::Quaterniond rotation(rotation_matrix);
    text += timestamp_text;
    for (int k = 0; k < 3; ++k) text += " " + format_fixed(translation[k], 9);
    text += " " + format_fixed(rotation.x(), 9) + " " + format_fixed(rotation.y(), 9) + " " +
            format_fixed(rotation.z(), 9) + " " + format_fixed(rotation.w(), 9) + "\n";
  }
  write_file_atomic(path, text);
}

}  // namespace panoscan
