// Reader of the scanning-positions file (<stem>.positions.json, format in sim/scene_loader.h), beside
// its writer (export.cpp): outside input, so every field is checked and named in the error.
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/scenes/scenes.h"

namespace fs = std::filesystem;

namespace panoscan::scenes {

namespace {

// Reads one number of a JSON array/field as a finite double, or throws naming the field.
double json_number(const nlohmann::json& value, const std::string& file, const std::string& field) {
  if (!value.is_number()) throw make_error(file, field, "expected a number");
  const double number = value.get<double>();
  if (!std::isfinite(number)) throw make_error(file, field, "not finite");
  return number;
}

Eigen::Vector3d json_point(const nlohmann::json& object, const char* key, const std::string& file,
                           const std::string& field) {
  if (!object.contains(key)) throw make_error(file, field, "missing");
  const nlohmann::json& value = object.at(key);
  if (!value.is_array() || value.size() != 3) throw make_error(file, field, "expected [x, y, z]");
  return Eigen::Vector3d(json_number(value[0], file, field + "[0]"), json_number(value[1], file, field + "[1]"),
                         json_number(value[2], file, field + "[2]"));
}

}  // namespace

void read_positions_file(const fs::path& path, Scene& scene) {
  const std::string file = path.string();
  const nlohmann::json document = read_json_file(path, "the positions file");
  if (!document.is_object()) throw make_error(file, "", "expected a JSON object");
  if (!document.contains("format") || document["format"] != "panoscan-positions")
    throw make_error(file, "format", "expected \"panoscan-positions\"");
  if (!document.contains("version") || !document["version"].is_number_integer() || document["version"] != 1)
    throw make_error(file, "version", "expected 1");
  if (!document.contains("positions") || !document["positions"].is_array() || document["positions"].empty())
    throw make_error(file, "positions", "expected a non-empty array of scanning positions");
  const nlohmann::json& positions = document["positions"];
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const std::string field = "positions[" + std::to_string(i) + "]";
    const nlohmann::json& entry = positions[i];
    if (!entry.is_object()) throw make_error(file, field, "expected an object");
    ScanPosition position;
    if (!entry.contains("name") || !entry["name"].is_string() || entry["name"].get<std::string>().empty())
      throw make_error(file, field + ".name", "missing or not a non-empty string");
    position.name = entry["name"].get<std::string>();
    position.floor_point = json_point(entry, "floor_point", file, field + ".floor_point");
    if (entry.contains("start_heading_deg"))
      position.start_heading_rad =
          json_number(entry["start_heading_deg"], file, field + ".start_heading_deg") * 3.14159265358979323846 / 180.0;
    for (const ScanPosition& earlier : scene.positions)
      if (earlier.name == position.name)
        throw make_error(file, field + ".name", "duplicate name '" + position.name + "'");
    scene.positions.push_back(position);
  }
  if (document.contains("lights")) {
    const nlohmann::json& lights = document["lights"];
    if (!lights.is_array()) throw make_error(file, "lights", "expected an array");
    for (std::size_t i = 0; i < lights.size(); ++i) {
      const std::string field = "lights[" + std::to_string(i) + "]";
      if (!lights[i].is_object()) throw make_error(file, field, "expected an object");
      PointLight light;
      light.position = json_point(lights[i], "position", file, field + ".position").cast<float>();
      if (lights[i].contains("intensity")) {
        const double intensity = json_number(lights[i]["intensity"], file, field + ".intensity");
        if (intensity < 0) throw make_error(file, field + ".intensity", "must not be negative");
        light.intensity = static_cast<float>(intensity);
      }
      scene.lights.push_back(light);
    }
  }
}

}  // namespace panoscan::scenes
