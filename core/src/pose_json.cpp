#include "panoscan/core/pose_json.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"

namespace panoscan {

namespace {

constexpr double kQuaternionNormTolerance = 1e-6;

// "object 123" style description of a JSON value for error messages (shortened).
std::string describe(const nlohmann::json& value) {
  std::string dumped = value.dump();
  if (dumped.size() > 40) dumped = dumped.substr(0, 37) + "...";
  return std::string(value.type_name()) + " " + dumped;
}

std::vector<double> numbers(const nlohmann::json& object, const char* name, std::size_t count, const std::string& file,
                            const std::string& field) {
  const std::string where = field + "." + name;
  if (!object.contains(name)) throw make_error(file, where, "missing field");
  const nlohmann::json& list = object.at(name);
  if (!list.is_array() || list.size() != count)
    throw make_error(file, where, "expected a list of " + std::to_string(count) + " numbers, found " + describe(list));
  std::vector<double> values;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string element = where + "[" + std::to_string(i) + "]";
    if (!list[i].is_number()) throw make_error(file, element, "expected a number, found " + describe(list[i]));
    values.push_back(list[i].get<double>());
    if (!std::isfinite(values.back())) throw make_error(file, element, "expected a finite number");
  }
  return values;
}

}  // namespace

nlohmann::json pose_to_json(const Rigid3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  return {{"translation", {pose.translation().x(), pose.translation().y(), pose.translation().z()}},
          {"rotation_quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

Rigid3d pose_from_json(const nlohmann::json& object, const std::string& file, const std::string& field) {
  if (!object.is_object()) throw make_error(file, field, "expected an object, found " + describe(object));
  for (const auto& item : object.items())
    if (item.key() != "translation" && item.key() != "rotation_quaternion_xyzw")
      throw make_error(file, field + "." + item.key(), "unknown field (a typo?)");
  const std::vector<double> t = numbers(object, "translation", 3, file, field);
  const std::vector<double> q = numbers(object, "rotation_quaternion_xyzw", 4, file, field);
  Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);  // Eigen's constructor order is (w, x, y, z)
  if (std::abs(rotation.norm() - 1.0) > kQuaternionNormTolerance)
    throw make_error(file, field + ".rotation_quaternion_xyzw",
                     "quaternion is not unit length (norm " + std::to_string(rotation.norm()) + ")");
  return make_rigid(rotation.normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
}

std::string pose_matrix_text(const Rigid3d& pose) {
  const Eigen::Matrix4d m = pose.matrix();
  std::string text;
  char buffer[64];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buffer, sizeof buffer, "%s%.17g", c ? " " : "", m(r, c) == 0.0 ? 0.0 : m(r, c));
      text += buffer;
    }
    text += "\n";
  }
  return text;
}

namespace {

Rigid3d read_matrix_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw make_error(file, "", "file not found (or not a regular file)");
  std::ifstream in(path);
  if (!in) throw make_error(file, "", "cannot open for reading");
  Eigen::Matrix4d m;
  int row = 0, line_number = 0;
  std::string line;
  while (std::getline(in, line)) {
    ++line_number;
    if (const std::size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    std::vector<std::string> tokens;
    for (std::string w; words >> w;) tokens.push_back(w);
    if (tokens.empty()) continue;
    const std::string where = "line " + std::to_string(line_number);
    if (row == 4) throw make_error(file, where, "more than 4 rows (expected a 4x4 matrix)");
    if (tokens.size() != 4)
      throw make_error(file, where, std::to_string(tokens.size()) + " numbers, expected 4 (a 4x4 matrix)");
    for (int c = 0; c < 4; ++c) {
      const std::string& t = tokens[c];
      double value = 0;
      const char* first = t.data() + (t.size() > 1 && t[0] == '+' ? 1 : 0);
      const auto [end, error] = std::from_chars(first, t.data() + t.size(), value);
      if (error != std::errc() || end != t.data() + t.size() || !std::isfinite(value))
        throw make_error(file, where, "'" + t + "' is not a finite number");
      m(row, c) = value;
    }
    ++row;
  }
  if (row != 4) throw make_error(file, "matrix", std::to_string(row) + " rows, expected 4 (a 4x4 matrix)");
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6)
    throw make_error(file, "matrix", "the last row must be 0 0 0 1 (a rigid transform)");
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if ((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || r.determinant() < 0)
    throw make_error(file, "matrix", "the upper-left 3x3 block is not a rotation (within 1e-6)");
  return make_rigid(closest_rotation(r), m.topRightCorner<3, 1>());
}

}  // namespace

Rigid3d read_pose_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  if (path.extension() == ".txt") return read_matrix_file(path);
  const nlohmann::json j = read_json_file(path, "expected a pose or an output of recon register");
  if (j.is_object() && j.contains("target_from_source"))
    return pose_from_json(j["target_from_source"], file, "target_from_source");
  return pose_from_json(j, file, "");
}

}  // namespace panoscan
