// `panoscan import tum` (tum_import.h): TUM RGB-D sequences into a scan folder through ScanWriter.

#include "panoscan/core/tum_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>

#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/log.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/tum_listing.h"
#include "panoscan/core/version.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The size the TUM presets are for.
constexpr int kPresetWidth = 640;
constexpr int kPresetHeight = 480;
// A 4x4 extrinsics matrix: its rotation block must be orthonormal to this before it is projected
// onto the closest rotation (hand-typed matrices carry a few decimals), its last row exact.
constexpr double kMatrixRotationTolerance = 1e-4;

struct SensorIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::string source;
  std::string preset;  // the preset's name when one was used (its image size is checked)
};

std::string line_of(const TumListingEntry& entry) { return "line " + std::to_string(entry.line_number); }

std::array<double, 4> parse_intrinsics(const std::string& text) {
  std::vector<std::string> items(1);
  for (char c : text) {
    if (c == ',') items.emplace_back();
    else items.back() += c;
  }
  if (items.size() != 4) throw make_error("--intrinsics", "", "'" + text + "': expected four numbers fx,fy,cx,cy");
  std::array<double, 4> values{};
  for (std::size_t i = 0; i < 4; ++i) {
    const std::string& item = items[i];
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || errno == ERANGE || !std::isfinite(value)) {
      throw make_error("--intrinsics", "", "'" + text + "': '" + item + "' is not a finite number");
    }
    values[i] = value;
  }
  if (!(values[0] > 0.0) || !(values[1] > 0.0)) {
    throw make_error("--intrinsics", "", "'" + text + "': fx and fy must be positive");
  }
  return values;
}

// Per sensor, from --intrinsics, --camera or the folder name.
std::vector<SensorIntrinsics> resolve_intrinsics(const TumImportOptions& options) {
  const std::size_t sensors = options.inputs.size();
  if (!options.intrinsics.empty() && !options.cameras.empty()) {
    throw make_error("--intrinsics", "", "give either --intrinsics or --camera, not both");
  }
  for (const auto& [list, name] : {std::pair(&options.intrinsics, "--intrinsics"), std::pair(&options.cameras, "--camera")}) {
    if (list->size() > 1 && list->size() != sensors) {
      throw make_error(name, "",
                       "given " + std::to_string(list->size()) + " times for " + std::to_string(sensors) +
                           " inputs: give it once (for every input) or once per input");
    }
  }
  std::vector<SensorIntrinsics> result(sensors);
  for (std::size_t k = 0; k < sensors; ++k) {
    SensorIntrinsics& out = result[k];
    if (!options.intrinsics.empty()) {
      const std::array<double, 4> v = parse_intrinsics(options.intrinsics[options.intrinsics.size() == 1 ? 0 : k]);
      out = {v[0], v[1], v[2], v[3], "--intrinsics", ""};
      continue;
    }
    std::string preset_name;
    if (!options.cameras.empty()) {
      preset_name = options.cameras[options.cameras.size() == 1 ? 0 : k];
      out.source = "--camera " + preset_name;
    } else {
      preset_name = tum_preset_for_folder(options.inputs[k]);
      if (preset_name.empty()) {
        throw make_error(options.inputs[k].string(), "",
                         "cannot tell the camera from the folder name (TUM's rgbd_dataset_freiburgN_*): give "
                         "--intrinsics fx,fy,cx,cy or --camera fr1|fr2|fr3|ros");
      }
      out.source = "folder name: " + preset_name;
    }
    const TumCameraPreset& preset = tum_camera_preset(preset_name, "--camera");
    out.fx = preset.fx;
    out.fy = preset.fy;
    out.cx = preset.cx;
    out.cy = preset.cy;
    out.preset = preset.name;
  }
  return result;
}

Rigid3d extrinsics_entry(const json& value, const std::string& file, const std::string& field) {
  if (value.is_object()) return pose_from_json(value, file, field);
  const bool matrix_shape = value.is_array() && value.size() == 4 && std::all_of(value.begin(), value.end(), [](const json& row) {
                              return row.is_array() && row.size() == 4 &&
                                     std::all_of(row.begin(), row.end(), [](const json& x) { return x.is_number(); });
                            });
  if (!matrix_shape) {
    throw make_error(file, field,
                     "expected a 4x4 matrix [[r00,r01,r02,tx],...,[0,0,0,1]] or a pose object "
                     "{\"translation\", \"rotation_quaternion_xyzw\"}");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = value[r][c].get<double>();
  if (!m.allFinite()) throw make_error(file, field, "contains non-finite numbers");
  if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) throw make_error(file, field, "the last row must be [0, 0, 0, 1]");
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kMatrixRotationTolerance ||
      rotation.determinant() < 0.0) {
    throw make_error(file, field, "the 3x3 block is not a rotation (orthonormal within 1e-4, determinant +1)");
  }
  return make_rigid(closest_rotation(rotation), Eigen::Vector3d(m.topRightCorner<3, 1>()));
}

// ref_from_cam per sensor and the reference index.
std::pair<std::vector<Rigid3d>, int> read_extrinsics(const TumImportOptions& options) {
  const std::size_t sensors = options.inputs.size();
  if (options.extrinsics_file.empty()) {
    if (sensors > 1) {
      throw make_error("--extrinsics", "",
                       "required for " + std::to_string(sensors) +
                           " inputs: a JSON file {\"ref_from_cam\": [one 4x4 matrix per input]}");
    }
    return {{Rigid3d::Identity()}, 0};
  }
  const std::string file = options.extrinsics_file.string();
  const json document = read_json_file(options.extrinsics_file, "expected {\"ref_from_cam\": [...]}");
  if (!document.is_object()) throw make_error(file, "", "expected a JSON object {\"ref_from_cam\": [...]}");
  for (const auto& item : document.items()) {
    if (item.key() != "ref_from_cam" && item.key() != "reference_sensor") {
      throw make_error(file, item.key(), "unknown field (known: ref_from_cam, reference_sensor)");
    }
  }
  int reference = 0;
  if (document.contains("reference_sensor")) {
    const json& value = document["reference_sensor"];
    if (!value.is_number_integer() || value.get<long long>() < 0 ||
        value.get<long long>() >= static_cast<long long>(sensors)) {
      throw make_error(file, "reference_sensor",
                       "expected an input index in [0, " + std::to_string(sensors - 1) + "], found " + value.dump());
    }
    reference = static_cast<int>(value.get<long long>());
  }
  if (!document.contains("ref_from_cam")) throw make_error(file, "ref_from_cam", "missing field");
  const json& list = document["ref_from_cam"];
  if (!list.is_array() || list.size() != sensors) {
    throw make_error(file, "ref_from_cam",
                     "expected a list of " + std::to_string(sensors) + " poses (one per --input), found " +
                         (list.is_array() ? std::to_string(list.size()) + " entries" : std::string(list.type_name())));
  }
  std::vector<Rigid3d> poses;
  for (std::size_t k = 0; k < sensors; ++k) {
    poses.push_back(extrinsics_entry(list[k], file, "ref_from_cam[" + std::to_string(k) + "]"));
  }
  const Rigid3d& own = poses[reference];
  if ((own.matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff() > 1e-9) {
    throw make_error(file, "ref_from_cam[" + std::to_string(reference) + "]",
                     "the reference sensor's pose in its own frame must be identity");
  }
  return {poses, reference};
}

// An image's size, with the listing line named in any error.
struct ImageSize {
  int width = 0, height = 0;
};

ImageSize check_rgb_image(const fs::path& path, const fs::path& listing, const TumListingEntry& entry) {
  try {
    if (image_file_format(path) == "PNG") {
      const PngHeader header = read_png_header(path);
      if (header.bit_depth != 8) {
        throw make_error(path.string(), "bit depth",
                         "expected an 8-bit colour image, found " + std::to_string(header.bit_depth) + "-bit");
      }
      return {header.width, header.height};
    }
    const ImageU8 image = read_rgb(path);  // another format: decoded once to check it
    return {image.width, image.height};
  } catch (const Error& e) {
    throw make_error(listing.string(), line_of(entry), e.what());
  }
}

ImageSize check_depth_image(const fs::path& path, const fs::path& listing, const TumListingEntry& entry) {
  try {
    const PngHeader header = read_png_header(path);
    if (header.bit_depth != 16 || header.channels != 1) {
      throw make_error(path.string(), "format",
                       "expected a 16-bit single-channel depth PNG, found " + std::to_string(header.channels) +
                           " channel(s) of " + std::to_string(header.bit_depth) + "-bit data");
    }
    return {header.width, header.height};
  } catch (const Error& e) {
    throw make_error(listing.string(), line_of(entry), e.what());
  }
}

double median_interval(const std::vector<TumListingEntry>& entries) {
  std::vector<double> intervals;
  for (std::size_t i = 1; i < entries.size(); ++i) intervals.push_back(entries[i].timestamp - entries[i - 1].timestamp);
  if (intervals.empty()) return 0.0;
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  return intervals[intervals.size() / 2];
}

struct SensorPlan {
  fs::path input, rgb_listing, depth_listing, groundtruth;
  std::vector<TumListingEntry> rgb, depth;
  std::vector<TimestampPair> pairs;
  ImageSize size;
  std::vector<StampedPose> groundtruth_poses;  // at the frames' timestamps, those covered
};

json report_json(const TumImportOptions& options, const TumImportReport& report) {
  json sensors = json::array();
  for (std::size_t k = 0; k < report.sensors.size(); ++k) {
    const TumImportSensorReport& s = report.sensors[k];
    const SensorInfo& info = report.rig.sensors[k];
    json sensor;
    sensor["name"] = info.name;
    sensor["input"] = fs::absolute(s.input).lexically_normal().string();
    sensor["intrinsics"] = {{"fx", info.intrinsics.fx}, {"fy", info.intrinsics.fy}, {"cx", info.intrinsics.cx},
                            {"cy", info.intrinsics.cy}, {"width", info.intrinsics.width},
                            {"height", info.intrinsics.height}, {"source", s.intrinsics_source}};
    sensor["rgb_listed"] = s.rgb_listed;
    sensor["depth_listed"] = s.depth_listed;
    sensor["frames"] = s.frames;
    sensor["rgb_dropped"] = s.rgb_dropped;
    sensor["depth_dropped"] = s.depth_dropped;
    sensor["max_abs_dt_s"] = s.max_abs_dt;
    if (s.has_groundtruth) {
      sensor["groundtruth"] = {{"poses", s.groundtruth_poses},
                               {"frames_with_pose", s.frames_with_pose},
                               {"frames_without_pose", s.frames - s.frames_with_pose}};
    } else {
      sensor["groundtruth"] = nullptr;
    }
    sensors.push_back(std::move(sensor));
  }
  json document;
  document["format"] = "panoscan-import";
  document["version"] = 1;
  document["importer"] = "tum";
  document["panoscan_version"] = project_version();
  document["source_revision"] = source_revision();
  document["options"] = {
      {"depth_scale", options.depth_scale},
      {"max_dt_s", options.max_dt},
      {"hard_link", options.hard_link},
      {"motion", to_string(options.motion)},
      {"extrinsics", options.extrinsics_file.empty() ? json(nullptr)
                                                     : json(fs::absolute(options.extrinsics_file).lexically_normal().string())},
      {"reference_sensor", report.rig.reference_sensor},
      {"frame_timestamp", "colour image"},
  };
  document["sensors"] = std::move(sensors);
  return document;
}

}  // namespace

const std::vector<TumCameraPreset>& tum_camera_presets() {
  static const std::vector<TumCameraPreset> presets = {
      {"fr1", 517.3, 516.5, 318.6, 255.3},
      {"fr2", 520.9, 521.0, 325.1, 249.7},
      {"fr3", 535.4, 539.2, 320.1, 247.6},
      {"ros", 525.0, 525.0, 319.5, 239.5},
  };
  return presets;
}

const TumCameraPreset& tum_camera_preset(const std::string& name, const std::string& origin) {
  std::string known;
  for (const TumCameraPreset& preset : tum_camera_presets()) {
    if (preset.name == name) return preset;
    known += (known.empty() ? "" : ", ") + preset.name;
  }
  throw make_error(origin, "", "unknown camera '" + name + "' (known: " + known + ")");
}

std::string tum_preset_for_folder(const fs::path& folder) {
  fs::path normal = folder.lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();  // a trailing slash
  std::string name = normal.filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  for (const char* digit : {"1", "2", "3"}) {
    if (name.find(std::string("freiburg") + digit) != std::string::npos) return std::string("fr") + digit;
  }
  return "";
}

TumImportReport import_tum(const TumImportOptions& options) {
  if (options.inputs.empty()) throw make_error("--input", "", "at least one TUM sequence folder is required");
  if (options.out.empty()) throw make_error("--out", "", "an output scan folder is required");
  if (!std::isfinite(options.depth_scale) || !(options.depth_scale > 0.0)) {
    throw make_error("--depth-scale", "", "expected a finite positive number, found " + std::to_string(options.depth_scale));
  }
  if (!std::isfinite(options.max_dt) || !(options.max_dt > 0.0)) {
    throw make_error("--max-dt", "", "expected a finite positive number of seconds, found " + std::to_string(options.max_dt));
  }
  std::error_code ec;
  if (fs::exists(options.out, ec) && !options.overwrite) {
    throw make_error(options.out.string(), "", "already exists (use --overwrite to replace it)");
  }
  const std::vector<SensorIntrinsics> intrinsics = resolve_intrinsics(options);
  const auto [extrinsics, reference] = read_extrinsics(options);

  // Everything is read and checked before the scan folder is started.
  std::vector<SensorPlan> plans(options.inputs.size());
  TumImportReport report;
  report.rig.reference_sensor = reference;
  report.rig.motion = options.motion;
  report.rig.description = "imported from TUM RGB-D sequence" + std::string(options.inputs.size() > 1 ? "s" : "") + ":";
  for (std::size_t k = 0; k < options.inputs.size(); ++k) {
    SensorPlan& plan = plans[k];
    plan.input = options.inputs[k];
    if (!fs::is_directory(plan.input, ec)) throw make_error(plan.input.string(), "", "TUM sequence folder not found");
    report.rig.description += " " + plan.input.lexically_normal().filename().string();
    plan.rgb_listing = plan.input / "rgb.txt";
    plan.depth_listing = plan.input / "depth.txt";
    plan.rgb = read_tum_listing(plan.rgb_listing, plan.input);
    plan.depth = read_tum_listing(plan.depth_listing, plan.input);
    std::vector<double> rgb_times, depth_times;
    for (const TumListingEntry& e : plan.rgb) rgb_times.push_back(e.timestamp);
    for (const TumListingEntry& e : plan.depth) depth_times.push_back(e.timestamp);
    plan.pairs = associate_timestamps(rgb_times, depth_times, options.max_dt);
    if (plan.pairs.empty()) {
      throw make_error(plan.depth_listing.string(), "",
                       "no depth image within " + std::to_string(options.max_dt) + " s of any colour image of " +
                           plan.rgb_listing.string() + " (colour " + plan.rgb.front().timestamp_text + " .. " +
                           plan.rgb.back().timestamp_text + ", depth " + plan.depth.front().timestamp_text + " .. " +
                           plan.depth.back().timestamp_text + "; see --max-dt)");
    }
    // Every paired image: colour 8-bit, depth a 16-bit single-channel PNG, all of one size.
    for (const TimestampPair& pair : plan.pairs) {
      const TumListingEntry& rgb = plan.rgb[pair.rgb];
      const TumListingEntry& depth = plan.depth[pair.depth];
      const ImageSize rgb_size = check_rgb_image(plan.input / rgb.file, plan.rgb_listing, rgb);
      const ImageSize depth_size = check_depth_image(plan.input / depth.file, plan.depth_listing, depth);
      if (plan.size.width == 0) plan.size = rgb_size;
      for (const auto& [size, listing, entry] :
           {std::tuple(rgb_size, &plan.rgb_listing, &rgb), std::tuple(depth_size, &plan.depth_listing, &depth)}) {
        if (size.width != plan.size.width || size.height != plan.size.height) {
          throw make_error(listing->string(), line_of(*entry),
                           (plan.input / entry->file).string() + " is " + std::to_string(size.width) + "x" +
                               std::to_string(size.height) + ", the first colour image " +
                               std::to_string(plan.size.width) + "x" + std::to_string(plan.size.height));
        }
      }
    }
    const SensorIntrinsics& k_intrinsics = intrinsics[k];
    if (!k_intrinsics.preset.empty() && (plan.size.width != kPresetWidth || plan.size.height != kPresetHeight)) {
      throw make_error(plan.input.string(), "",
                       "the camera preset " + k_intrinsics.preset + " (" + k_intrinsics.source + ") is for " +
                           std::to_string(kPresetWidth) + "x" + std::to_string(kPresetHeight) +
                           " images, these are " + std::to_string(plan.size.width) + "x" +
                           std::to_string(plan.size.height) + ": give --intrinsics fx,fy,cx,cy");
    }

    SensorInfo sensor;
    sensor.name = "cam" + std::to_string(k);
    sensor.intrinsics.width = plan.size.width;
    sensor.intrinsics.height = plan.size.height;
    sensor.intrinsics.fx = k_intrinsics.fx;
    sensor.intrinsics.fy = k_intrinsics.fy;
    sensor.intrinsics.cx = k_intrinsics.cx;
    sensor.intrinsics.cy = k_intrinsics.cy;
    sensor.depth_scale = options.depth_scale;
    const double interval = median_interval(plan.rgb);
    sensor.nominal_fps = interval > 0.0 ? 1.0 / interval : 30.0;
    sensor.ref_from_cam = extrinsics[k];
    report.rig.sensors.push_back(sensor);

    TumImportSensorReport sensor_report;
    sensor_report.input = plan.input;
    sensor_report.intrinsics_source = k_intrinsics.source;
    sensor_report.rgb_listed = plan.rgb.size();
    sensor_report.depth_listed = plan.depth.size();
    sensor_report.frames = plan.pairs.size();
    sensor_report.rgb_dropped = plan.rgb.size() - plan.pairs.size();
    sensor_report.depth_dropped = plan.depth.size() - plan.pairs.size();
    for (const TimestampPair& pair : plan.pairs) sensor_report.max_abs_dt = std::max(sensor_report.max_abs_dt, std::abs(pair.dt));

    plan.groundtruth = plan.input / "groundtruth.txt";
    if (fs::exists(plan.groundtruth, ec)) {
      const std::vector<StampedPose> truth = read_tum_trajectory(plan.groundtruth);
      std::vector<double> frame_times;
      for (const TimestampPair& pair : plan.pairs) frame_times.push_back(plan.rgb[pair.rgb].timestamp);
      const std::vector<std::optional<Rigid3d>> poses = interpolate_trajectory(truth, frame_times, options.max_dt);
      for (std::size_t f = 0; f < poses.size(); ++f) {
        if (poses[f]) plan.groundtruth_poses.push_back({frame_times[f], *poses[f]});
      }
      sensor_report.has_groundtruth = true;
      sensor_report.groundtruth_poses = truth.size();
      sensor_report.frames_with_pose = plan.groundtruth_poses.size();
      if (plan.groundtruth_poses.size() < plan.pairs.size()) {
        log_warn(plan.groundtruth.string() + ": " + std::to_string(plan.pairs.size() - plan.groundtruth_poses.size()) +
                 " of " + std::to_string(plan.pairs.size()) + " frames have no ground-truth pose within " +
                 std::to_string(options.max_dt) + " s");
      }
    }
    report.sensors.push_back(sensor_report);
  }

  ScanWriter writer(options.out, report.rig, options.overwrite);
  const auto transfer = options.hard_link ? ScanWriter::FileTransfer::kHardLink : ScanWriter::FileTransfer::kCopy;
  for (std::size_t k = 0; k < plans.size(); ++k) {
    const SensorPlan& plan = plans[k];
    for (const TimestampPair& pair : plan.pairs) {
      const TumListingEntry& rgb = plan.rgb[pair.rgb];
      try {
        writer.add_frame_files(int(k), rgb.timestamp, plan.input / rgb.file, plan.input / plan.depth[pair.depth].file,
                               transfer);
      } catch (const Error& e) {
        throw make_error(plan.rgb_listing.string(), line_of(rgb), e.what());
      }
    }
    if (!plan.groundtruth_poses.empty()) writer.write_groundtruth_trajectory(int(k), plan.groundtruth_poses);
  }
  write_file_atomic(writer.temp_path("import.json"), report_json(options, report).dump(2) + "\n");
  writer.commit();
  return report;
}

}  // namespace panoscan
