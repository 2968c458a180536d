// The scan format (docs/ARCHITECTURE.md §5): reading, validating and atomically writing a scan directory.
//
// rig.json, format "panoscan-scan", version 1. Every field is required unless marked optional;
// unknown fields are rejected (a misspelt field must not be silently ignored).
//
//   {
//     "format": "panoscan-scan",          string, exactly this
//     "version": 1,                       integer, exactly 1 (other versions are refused)
//     "description": "simulated: ...",    string, optional (default "")
//     "reference_sensor": 0,              integer index into "sensors"; its ref_from_cam must be identity
//     "motion": "rotator",                string, optional (default "rotator"): "rotator" or "handheld"
//     "sensors": [                        non-empty list
//       {
//         "name": "cam0",                 string of letters, digits, '_' and '-', unique, not "groundtruth";
//                                         also the sub-directory holding the sensor's images
//         "width": 640, "height": 480,    integers > 0 (image size in pixels, colour and depth alike)
//         "fx": 570.0, "fy": 570.0,       numbers > 0 (focal lengths in pixels)
//         "cx": 319.5, "cy": 239.5,       finite numbers (principal point; pixel centres at integers)
//         "depth_scale": 5000.0,          number > 0: depth PNG units per metre
//         "nominal_fps": 30.0,            number > 0: nominal frame rate (actual timestamps are in the listings)
//         "ref_from_cam": {               calibrated pose of this camera in the reference camera's frame
//           "translation": [x, y, z],     metres, 3 finite numbers
//           "rotation_quaternion_xyzw": [qx, qy, qz, qw]   4 finite numbers, unit length (within 1e-6)
//         }
//       }, ...
//     ]
//   }
//
// Per sensor <name>/rgb.txt and <name>/depth.txt are TUM listings: lines "timestamp filename"
// (filename relative to <name>/), '#' starts a comment line. Timestamps are written with 6
// decimals, strictly increase, and both listings hold the same timestamps. The writer names
// the images <name>/rgb/<timestamp>.png and <name>/depth/<timestamp>.png.
//
// groundtruth/ (simulated scans; read by eval and tests, never by reconstruction) holds <name>.txt
// (TUM trajectory, world_from_cam), rig_truth.json, mesh.ply, and optionally, per frame and named
// by the frame's timestamp like the images:
//   depth_clean/<name>/<timestamp>.png   16-bit noiseless z, depth_scale units per metre
//   normals/<name>/<timestamp>.exr       float channels R, G, B: the hit triangle's unit normal in
//                                        the camera frame (x right, y down, z forward), facing the
//                                        camera; 0 where nothing is hit
//   ids/<name>/<timestamp>.exr           32-bit UINT channels triangle_id (index into mesh.ply's
//                                        faces) and material_id (index into the scene's materials),
//                                        int32 by bit pattern: 4294967295 = -1 = nothing hit (and
//                                        material_id -1 for a mesh without materials)

#include "panoscan/core/scan.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PANOSCAN_DEPTH_UNITS_AVX2 1
#endif

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/cpu_features.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/tum_listing.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kRigFileName = "rig.json";
constexpr const char* kGroundtruthDirName = "groundtruth";
constexpr const char* kListingHeader = "# timestamp filename\n";
// Sub-folders of groundtruth/ for the per-frame ground truth, and the EXR channels they hold.
constexpr const char* kCleanDepthDirName = "depth_clean";
constexpr const char* kNormalsDirName = "normals";
constexpr const char* kIdsDirName = "ids";
const std::vector<std::string>& normal_channels() {
  static const std::vector<std::string> names = {"R", "G", "B"};
  return names;
}
const std::vector<std::string>& id_channels() {
  static const std::vector<std::string> names = {"triangle_id", "material_id"};
  return names;
}
// Guards against absurd sizes whose pixel count would overflow or exhaust memory.
constexpr int kMaxImageSide = 1 << 15;
// A stored quaternion must be unit length to this tolerance (rig.json keeps full double precision).
// The reference camera's ref_from_cam must be identity to this tolerance.
constexpr double kReferenceIdentityTolerance = 1e-9;
// Rotation matrices in a RigInfo must be orthonormal to this tolerance.
constexpr double kOrthonormalTolerance = 1e-6;

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string read_text_file(const fs::path& path, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw make_error(path.string(), "", what + " not found");
  if (fs::is_directory(path, ec)) throw make_error(path.string(), "", "is a directory, expected " + what);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw make_error(path.string(), "", "cannot open " + what + " for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw make_error(path.string(), "", "error while reading " + what);
  return text.str();
}

bool is_valid_sensor_name(const std::string& name) {
  if (name.empty() || name == kGroundtruthDirName) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

// ---- rig.json field readers: each throws Error naming the origin and the dotted field. ----

const json& require_field(const json& object, const std::string& key, const std::string& origin,
                          const std::string& object_field) {
  const auto it = object.find(key);
  const std::string field = object_field.empty() ? key : object_field + "." + key;
  if (it == object.end()) throw make_error(origin, field, "missing field");
  return *it;
}

std::string json_type_text(const json& value) {
  std::string dumped = value.dump();
  if (dumped.size() > 40) dumped = dumped.substr(0, 37) + "...";
  return std::string(value.type_name()) + " " + dumped;
}

double read_number(const json& value, const std::string& origin, const std::string& field) {
  if (!value.is_number()) throw make_error(origin, field, "expected a number, found " + json_type_text(value));
  const double number = value.get<double>();
  if (!std::isfinite(number)) throw make_error(origin, field, "expected a finite number");
  return number;
}

double read_positive_number(const json& value, const std::string& origin, const std::string& field) {
  const double number = read_number(value, origin, field);
  if (!(number > 0.0)) throw make_error(origin, field, "expected a positive number, found " + value.dump());
  return number;
}

long long read_integer(const json& value, const std::string& origin, const std::string& field) {
  if (!value.is_number_integer())
    throw make_error(origin, field, "expected an integer, found " + json_type_text(value));
  if (value.is_number_unsigned()) {
    const auto unsigned_value = value.get<std::uint64_t>();
    if (unsigned_value > static_cast<std::uint64_t>(std::numeric_limits<long long>::max())) {
      throw make_error(origin, field, "integer " + value.dump() + " is too large");
    }
  }
  return value.get<long long>();
}

std::string read_string(const json& value, const std::string& origin, const std::string& field) {
  if (!value.is_string()) throw make_error(origin, field, "expected a string, found " + json_type_text(value));
  return value.get<std::string>();
}

void reject_unknown_fields(const json& object, const std::set<std::string>& known, const std::string& origin,
                           const std::string& object_field) {
  for (const auto& item : object.items()) {
    if (!known.count(item.key())) {
      const std::string field = object_field.empty() ? item.key() : object_field + "." + item.key();
      throw make_error(
          origin, field,
          "unknown field (a typo? this is rig.json format version " + std::to_string(kScanFormatVersion) + ")");
    }
  }
}

// Checks the invariants of a RigInfo, whether it was read from rig.json or built in memory
// (the writer validates before writing, so that it never produces a rig.json the reader refuses).
void validate_rig(const RigInfo& rig, const std::string& origin) {
  if (rig.sensors.empty()) throw make_error(origin, "sensors", "the rig has no sensors");
  if (rig.reference_sensor < 0 || rig.reference_sensor >= static_cast<int>(rig.sensors.size())) {
    throw make_error(origin, "reference_sensor",
                     "index " + std::to_string(rig.reference_sensor) + " is out of range (the rig has " +
                         std::to_string(rig.sensors.size()) + " sensors)");
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < rig.sensors.size(); ++i) {
    const SensorInfo& sensor = rig.sensors[i];
    const std::string field = "sensors[" + std::to_string(i) + "]";
    if (!is_valid_sensor_name(sensor.name)) {
      throw make_error(
          origin, field + ".name",
          "'" + sensor.name + "' is not a valid sensor name (letters, digits, '_' and '-' only; not 'groundtruth')");
    }
    if (!names.insert(sensor.name).second) {
      throw make_error(origin, field + ".name", "sensor name '" + sensor.name + "' is used twice");
    }
    const PinholeIntrinsics& k = sensor.intrinsics;
    if (k.width <= 0 || k.width > kMaxImageSide) {
      throw make_error(
          origin, field + ".width",
          "expected an integer in [1, " + std::to_string(kMaxImageSide) + "], found " + std::to_string(k.width));
    }
    if (k.height <= 0 || k.height > kMaxImageSide) {
      throw make_error(
          origin, field + ".height",
          "expected an integer in [1, " + std::to_string(kMaxImageSide) + "], found " + std::to_string(k.height));
    }
    const std::pair<const char*, double> positive_values[] = {
        {"fx", k.fx}, {"fy", k.fy}, {"depth_scale", sensor.depth_scale}, {"nominal_fps", sensor.nominal_fps}};
    for (const auto& [name, value] : positive_values) {
      if (!std::isfinite(value) || !(value > 0.0)) {
        throw make_error(origin, field + "." + name,
                         "expected a finite positive number, found " + std::to_string(value));
      }
    }
    if (!std::isfinite(k.cx)) throw make_error(origin, field + ".cx", "expected a finite number");
    if (!std::isfinite(k.cy)) throw make_error(origin, field + ".cy", "expected a finite number");
    const Eigen::Matrix3d rotation = sensor.ref_from_cam.linear();
    const Eigen::Vector3d translation = sensor.ref_from_cam.translation();
    if (!rotation.allFinite() || !translation.allFinite()) {
      throw make_error(origin, field + ".ref_from_cam", "contains non-finite numbers");
    }
    if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kOrthonormalTolerance ||
        rotation.determinant() < 0.0) {
      throw make_error(origin, field + ".ref_from_cam", "the rotation is not a proper rotation matrix");
    }
  }
  const Rigid3d& reference_pose = rig.sensors[rig.reference_sensor].ref_from_cam;
  const double deviation = std::max((reference_pose.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(),
                                    reference_pose.translation().cwiseAbs().maxCoeff());
  if (deviation > kReferenceIdentityTolerance) {
    throw make_error(origin, "sensors[" + std::to_string(rig.reference_sensor) + "].ref_from_cam",
                     "the reference sensor's pose in its own frame must be identity");
  }
}

RigInfo read_rig_file(const fs::path& scan_dir) {
  const fs::path path = scan_dir / kRigFileName;
  return rig_from_json(read_text_file(path, "rig file"), path.string());
}

// ---- TUM listings ("timestamp filename"): read_tum_listing (tum_listing.h) ----

// Pairs the two listings of one camera; both must hold exactly the same timestamps.
std::vector<FrameEntry> pair_listings(const std::vector<TumListingEntry>& rgb, const fs::path& rgb_listing,
                                      const std::vector<TumListingEntry>& depth, const fs::path& depth_listing) {
  std::vector<FrameEntry> frames;
  std::size_t r = 0;
  std::size_t d = 0;
  while (r < rgb.size() || d < depth.size()) {
    // Both lists strictly increase, so the smaller current timestamp is absent from the other list.
    const bool rgb_lacks = r == rgb.size() || (d < depth.size() && depth[d].timestamp < rgb[r].timestamp);
    const bool depth_lacks = d == depth.size() || (r < rgb.size() && rgb[r].timestamp < depth[d].timestamp);
    if (rgb_lacks) {
      throw make_error(rgb_listing.string(), "timestamp " + depth[d].timestamp_text,
                       "missing here but listed in " + depth_listing.string() + " (line " +
                           std::to_string(depth[d].line_number) + ")");
    }
    if (depth_lacks) {
      throw make_error(
          depth_listing.string(), "timestamp " + rgb[r].timestamp_text,
          "missing here but listed in " + rgb_listing.string() + " (line " + std::to_string(rgb[r].line_number) + ")");
    }
    FrameEntry frame;
    frame.timestamp = rgb[r].timestamp;
    frame.rgb_file = rgb[r].file;
    frame.depth_file = depth[d].file;
    frames.push_back(std::move(frame));
    ++r;
    ++d;
  }
  return frames;
}

void check_image_size(const std::string& file, int width, int height, const PinholeIntrinsics& intrinsics) {
  if (width != intrinsics.width || height != intrinsics.height) {
    throw make_error(
        file, "image size",
        "expected " + size_text(intrinsics.width, intrinsics.height) + ", found " + size_text(width, height));
  }
}

template <typename T>
void check_image_shape(const Image<T>& image, int channels, const std::string& origin, const std::string& field) {
  if (image.channels != channels || image.width < 0 || image.height < 0 ||
      image.data.size() != std::size_t(image.width) * image.height * image.channels) {
    throw make_error(origin, field,
                     "expected a " + std::to_string(channels) + "-channel image, found " +
                         std::to_string(image.channels) + " channels, " + size_text(image.width, image.height) + ", " +
                         std::to_string(image.data.size()) + " values");
  }
}

void check_depth_scale(double depth_scale) {
  if (!std::isfinite(depth_scale) || !(depth_scale > 0.0)) {
    throw make_error("", "depth_scale", "expected a finite positive number, found " + std::to_string(depth_scale));
  }
}

}  // namespace

// ---- rig.json ----

const char* to_string(RigMotion motion) { return motion == RigMotion::kHandheld ? "handheld" : "rotator"; }

RigMotion rig_motion_from_string(const std::string& text, const std::string& origin, const std::string& field) {
  if (text == "rotator") return RigMotion::kRotator;
  if (text == "handheld") return RigMotion::kHandheld;
  throw make_error(origin, field, "expected 'rotator' or 'handheld', found '" + text + "'");
}

std::string rig_to_json(const RigInfo& rig) {
  validate_rig(rig, "rig");
  json sensors = json::array();
  for (const SensorInfo& sensor : rig.sensors) {
    json sensor_json;
    sensor_json["name"] = sensor.name;
    sensor_json["width"] = sensor.intrinsics.width;
    sensor_json["height"] = sensor.intrinsics.height;
    sensor_json["fx"] = sensor.intrinsics.fx;
    sensor_json["fy"] = sensor.intrinsics.fy;
    sensor_json["cx"] = sensor.intrinsics.cx;
    sensor_json["cy"] = sensor.intrinsics.cy;
    sensor_json["depth_scale"] = sensor.depth_scale;
    sensor_json["nominal_fps"] = sensor.nominal_fps;
    sensor_json["ref_from_cam"] = pose_to_json(sensor.ref_from_cam);
    sensors.push_back(std::move(sensor_json));
  }
  json document;
  document["format"] = kScanFormatName;
  document["version"] = kScanFormatVersion;
  document["description"] = rig.description;
  document["reference_sensor"] = rig.reference_sensor;
  document["motion"] = to_string(rig.motion);
  document["sensors"] = std::move(sensors);
  // nlohmann writes doubles with enough digits to read back the same value.
  return document.dump(2) + "\n";
}

RigInfo rig_from_json(const std::string& text, const std::string& origin) {
  const json document = parse_json_text(text, origin);
  if (!document.is_object()) throw make_error(origin, "", "expected a JSON object at the top level");

  // Format and version first: a file of another version may legitimately lack our fields.
  const std::string format = read_string(require_field(document, "format", origin, ""), origin, "format");
  if (format != kScanFormatName) {
    throw make_error(origin, "format", "expected '" + std::string(kScanFormatName) + "', found '" + format + "'");
  }
  const long long version = read_integer(require_field(document, "version", origin, ""), origin, "version");
  if (version != kScanFormatVersion) {
    throw make_error(origin, "version",
                     "expected " + std::to_string(kScanFormatVersion) + ", found " + std::to_string(version));
  }
  reject_unknown_fields(document, {"format", "version", "description", "reference_sensor", "motion", "sensors"}, origin,
                        "");

  RigInfo rig;
  if (document.contains("description")) {
    rig.description = read_string(document["description"], origin, "description");
  }
  // Absent in scans written before the field existed: those are all rotator scans.
  if (document.contains("motion")) {
    rig.motion = rig_motion_from_string(read_string(document["motion"], origin, "motion"), origin, "motion");
  }
  const long long reference =
      read_integer(require_field(document, "reference_sensor", origin, ""), origin, "reference_sensor");
  const json& sensors = require_field(document, "sensors", origin, "");
  if (!sensors.is_array()) throw make_error(origin, "sensors", "expected a list, found " + json_type_text(sensors));
  if (sensors.empty()) throw make_error(origin, "sensors", "the rig has no sensors");
  if (reference < 0 || reference >= static_cast<long long>(sensors.size())) {
    throw make_error(origin, "reference_sensor",
                     "index " + std::to_string(reference) + " is out of range (the rig has " +
                         std::to_string(sensors.size()) + " sensors)");
  }
  rig.reference_sensor = static_cast<int>(reference);

  for (std::size_t i = 0; i < sensors.size(); ++i) {
    const json& sensor_json = sensors[i];
    const std::string field = "sensors[" + std::to_string(i) + "]";
    if (!sensor_json.is_object())
      throw make_error(origin, field, "expected an object, found " + json_type_text(sensor_json));
    reject_unknown_fields(
        sensor_json, {"name", "width", "height", "fx", "fy", "cx", "cy", "depth_scale", "nominal_fps", "ref_from_cam"},
        origin, field);
    auto required = [&](const char* key) -> const json& { return require_field(sensor_json, key, origin, field); };
    auto sub = [&](const char* key) { return field + "." + key; };

    SensorInfo sensor;
    sensor.name = read_string(required("name"), origin, sub("name"));
    auto read_image_side = [&](const char* key) {
      const long long value = read_integer(required(key), origin, sub(key));
      if (value <= 0 || value > kMaxImageSide) {
        throw make_error(
            origin, sub(key),
            "expected an integer in [1, " + std::to_string(kMaxImageSide) + "], found " + std::to_string(value));
      }
      return static_cast<int>(value);
    };
    sensor.intrinsics.width = read_image_side("width");
    sensor.intrinsics.height = read_image_side("height");
    sensor.intrinsics.fx = read_positive_number(required("fx"), origin, sub("fx"));
    sensor.intrinsics.fy = read_positive_number(required("fy"), origin, sub("fy"));
    sensor.intrinsics.cx = read_number(required("cx"), origin, sub("cx"));
    sensor.intrinsics.cy = read_number(required("cy"), origin, sub("cy"));
    sensor.depth_scale = read_positive_number(required("depth_scale"), origin, sub("depth_scale"));
    sensor.nominal_fps = read_positive_number(required("nominal_fps"), origin, sub("nominal_fps"));
    sensor.ref_from_cam = pose_from_json(required("ref_from_cam"), origin, sub("ref_from_cam"));
    rig.sensors.push_back(std::move(sensor));
  }
  validate_rig(rig, origin);  // names, duplicates, reference identity
  return rig;
}

// ---- reading ----

ScanIndex read_scan_index(const fs::path& scan_dir) {
  std::error_code ec;
  if (!fs::is_directory(scan_dir, ec)) throw make_error(scan_dir.string(), "", "scan directory not found");
  ScanIndex scan;
  scan.root = scan_dir;
  scan.rig = read_rig_file(scan_dir);
  for (const SensorInfo& sensor : scan.rig.sensors) {
    const fs::path camera_dir = scan_dir / sensor.name;
    const fs::path rgb_listing = camera_dir / "rgb.txt";
    const fs::path depth_listing = camera_dir / "depth.txt";
    const std::vector<TumListingEntry> rgb = read_tum_listing(rgb_listing, camera_dir);
    const std::vector<TumListingEntry> depth = read_tum_listing(depth_listing, camera_dir);
    scan.frames.push_back(pair_listings(rgb, rgb_listing, depth, depth_listing));
  }
  return scan;
}

RgbdFrame load_frame(const ScanIndex& scan, int sensor, std::size_t frame_index) {
  if (sensor < 0 || sensor >= static_cast<int>(scan.rig.sensors.size()) ||
      scan.frames.size() != scan.rig.sensors.size()) {
    throw make_error(scan.root.string(), "sensor",
                     "index " + std::to_string(sensor) + " is out of range (the rig has " +
                         std::to_string(scan.rig.sensors.size()) + " sensors)");
  }
  const SensorInfo& info = scan.rig.sensors[sensor];
  if (frame_index >= scan.frames[sensor].size()) {
    throw make_error(scan.root.string(), info.name,
                     "frame " + std::to_string(frame_index) + " is out of range (" +
                         std::to_string(scan.frames[sensor].size()) + " frames)");
  }
  const FrameEntry& entry = scan.frames[sensor][frame_index];
  const fs::path camera_dir = scan.root / info.name;
  const fs::path rgb_path = camera_dir / entry.rgb_file;
  const fs::path depth_path = camera_dir / entry.depth_file;

  RgbdFrame frame;
  frame.timestamp = entry.timestamp;
  frame.rgb = read_rgb(rgb_path);
  check_image_size(rgb_path.string(), frame.rgb.width, frame.rgb.height, info.intrinsics);
  const ImageU16 depth_units = read_png16(depth_path);
  check_image_size(depth_path.string(), depth_units.width, depth_units.height, info.intrinsics);
  frame.depth = depth_from_png_units(depth_units, info.depth_scale);
  return frame;
}

fs::path groundtruth_dir(const fs::path& scan_dir) { return scan_dir / kGroundtruthDirName; }

std::vector<StampedPose> read_groundtruth_trajectory(const fs::path& scan_dir, int sensor) {
  const RigInfo rig = read_rig_file(scan_dir);
  if (sensor < 0 || sensor >= static_cast<int>(rig.sensors.size())) {
    throw make_error((scan_dir / kRigFileName).string(), "sensors",
                     "sensor index " + std::to_string(sensor) + " is out of range (the rig has " +
                         std::to_string(rig.sensors.size()) + " sensors)");
  }
  return read_tum_trajectory(groundtruth_dir(scan_dir) / (rig.sensors[sensor].name + ".txt"));
}

fs::path groundtruth_normals_path(const fs::path& scan_dir, const std::string& sensor_name, double timestamp) {
  return groundtruth_dir(scan_dir) / kNormalsDirName / sensor_name / (format_timestamp(timestamp) + ".exr");
}

fs::path groundtruth_ids_path(const fs::path& scan_dir, const std::string& sensor_name, double timestamp) {
  return groundtruth_dir(scan_dir) / kIdsDirName / sensor_name / (format_timestamp(timestamp) + ".exr");
}

namespace {

const SensorInfo& indexed_sensor(const ScanIndex& scan, int sensor) {
  if (sensor < 0 || sensor >= static_cast<int>(scan.rig.sensors.size()))
    throw make_error(scan.root.string(), "sensor",
                     "index " + std::to_string(sensor) + " is out of range (the rig has " +
                         std::to_string(scan.rig.sensors.size()) + " sensors)");
  return scan.rig.sensors[sensor];
}

}  // namespace

ImageF32 read_groundtruth_normals(const ScanIndex& scan, int sensor, double timestamp) {
  const SensorInfo& info = indexed_sensor(scan, sensor);
  return read_exr(groundtruth_normals_path(scan.root, info.name, timestamp), normal_channels(), info.intrinsics.width,
                  info.intrinsics.height);
}

ImageI32 read_groundtruth_ids(const ScanIndex& scan, int sensor, double timestamp) {
  const SensorInfo& info = indexed_sensor(scan, sensor);
  const fs::path path = groundtruth_ids_path(scan.root, info.name, timestamp);
  ImageI32 ids = read_exr_i32(path, id_channels(), info.intrinsics.width, info.intrinsics.height);
  for (std::size_t i = 0; i < ids.data.size(); ++i)
    if (ids.data[i] < -1)
      throw make_error(path.string(), "channel " + id_channels()[i % 2],
                       "value " + std::to_string(std::uint32_t(ids.data[i])) + " at pixel " + std::to_string(i / 2) +
                           " is neither an index (below 2^31) nor 4294967295 (nothing hit)");
  return ids;
}

// ---- depth units ----

#if PANOSCAN_DEPTH_UNITS_AVX2
namespace {

// depth_to_png_units' loop for the pixels [0, n / 4 * 4), four per AVX2 operation, each lane the
// scalar loop's double operations: valid where 0 < z < inf and z * scale <= 65535.5, then rounded half
// up from the truncation and kept where <= 65535; 0 elsewhere. Returns the first pixel not done. The
// scalar loop was 2% of a sim run.
__attribute__((target("avx2"))) std::size_t depth_units_avx2(const float* depth, std::size_t n, double depth_scale,
                                                             std::uint16_t* units) {
  const __m256d zero = _mm256_setzero_pd(), infinity = _mm256_set1_pd(std::numeric_limits<double>::infinity());
  const __m256d scale = _mm256_set1_pd(depth_scale), limit = _mm256_set1_pd(65535.5), half = _mm256_set1_pd(0.5);
  const std::size_t end = n / 4 * 4;
  for (std::size_t i = 0; i < end; i += 4) {
    const __m256d z = _mm256_cvtps_pd(_mm_loadu_ps(depth + i));
    const __m256d scaled = _mm256_mul_pd(z, scale);
    const __m256d in_range =
        _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(z, zero, _CMP_GT_OQ), _mm256_cmp_pd(z, infinity, _CMP_LT_OQ)),
                      _mm256_cmp_pd(scaled, limit, _CMP_LE_OQ));
    // Out-of-range lanes convert 0 (their product may be beyond int32) and are zeroed below.
    const __m256d safe = _mm256_and_pd(scaled, in_range);
    const __m128i truncated = _mm256_cvttpd_epi32(safe);
    const __m256d fraction = _mm256_sub_pd(safe, _mm256_cvtepi32_pd(truncated));
    const __m128i round_up =
        _mm256_cvtpd_epi32(_mm256_and_pd(_mm256_cmp_pd(fraction, half, _CMP_GE_OQ), _mm256_set1_pd(1.0)));
    const __m128i rounded = _mm_add_epi32(truncated, round_up);
    // The 64-bit lane masks narrowed to 32 bits: a double's mask is all ones or all zeros, so its low
    // half is the lane's 32-bit mask.
    const __m128i lane_mask = _mm256_castsi256_si128(
        _mm256_permutevar8x32_epi32(_mm256_castpd_si256(in_range), _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6)));
    const __m128i value =
        _mm_and_si128(_mm_and_si128(rounded, lane_mask), _mm_cmpgt_epi32(_mm_set1_epi32(65536), rounded));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(units + i), _mm_packus_epi32(value, value));
  }
  return end;
}


}  // namespace
#endif

ImageU16 depth_to_png_units(const ImageF32& depth_m, double depth_scale) {
  check_depth_scale(depth_scale);
  check_image_shape(depth_m, 1, "", "depth");
  // Not zero-filled: both loops below write every pixel, 0 where there is no measurement.
  ImageU16 units = ImageU16::uninitialised(depth_m.width, depth_m.height, 1);
  std::size_t first = 0;
#if PANOSCAN_DEPTH_UNITS_AVX2
  if (cpu::has_avx2())
    first = depth_units_avx2(depth_m.data.data(), depth_m.data.size(), depth_scale, units.data.data());
#endif
  for (std::size_t i = first; i < depth_m.data.size(); ++i) {
    units.data[i] = 0;
    const double z = depth_m.data[i];
    // NaN, infinity, zero and negative depths are all "no measurement".
    if (!std::isfinite(z) || !(z > 0.0)) continue;
    const double scaled = z * depth_scale;
    if (scaled > 65535.5) continue;  // beyond the 16-bit range: invalid rather than clipped
    // std::lround for a positive value (half away from zero), without its libm call per pixel: the
    // fraction x - trunc(x) is exact for any x below 2^52.
    const long truncated = static_cast<long>(scaled);
    const long rounded = truncated + (scaled - double(truncated) >= 0.5);
    if (rounded > 65535) continue;
    units.data[i] = static_cast<std::uint16_t>(rounded);
  }
  return units;
}

ImageF32 depth_from_png_units(const ImageU16& depth, double depth_scale) {
  check_depth_scale(depth_scale);
  check_image_shape(depth, 1, "", "depth");
  ImageF32 metres = ImageF32::uninitialised(depth.width, depth.height, 1);  // every pixel written below
  // The quotient of every 16-bit value, computed once per scale and thread (the same float as the
  // division per pixel, 0 for 0): a load per pixel instead of a double division, which was 2% of
  // the front end's instructions and more of its time.
  thread_local std::vector<float> metres_of_units;
  thread_local double table_scale = 0.0;
  if (metres_of_units.empty() || table_scale != depth_scale) {
    metres_of_units.resize(65536);
    for (std::size_t u = 0; u < metres_of_units.size(); ++u)
      metres_of_units[u] = static_cast<float>(double(u) / depth_scale);
    table_scale = depth_scale;
  }
  const std::uint16_t* units = depth.data.data();
  const float* table = metres_of_units.data();
  float* out = metres.data.data();
  for (std::size_t i = 0; i < depth.data.size(); ++i) out[i] = table[units[i]];
  return metres;
}

// ---- writing ----

struct ScanWriter::Impl {
  struct SensorState {
    std::vector<FrameEntry> frames;  // successfully written frames
    bool has_timestamp = false;
    double last_timestamp = 0.0;  // as read back from its 6-decimal text
  };

  fs::path scan_dir;
  RigInfo rig;
  int png_compression = 1;
  std::unique_ptr<AtomicDirectory> directory;
  // Guards the bookkeeping below; image encoding runs outside it so sensors write in parallel.
  std::mutex mutex;
  std::vector<SensorState> sensors;
  bool committed = false;

  std::string origin() const { return scan_dir.string(); }

  void check_not_committed() const {
    if (committed) throw make_error(origin(), "", "the scan was already committed; no further writes");
  }

  const SensorInfo& sensor_info(int sensor) const {
    if (sensor < 0 || sensor >= static_cast<int>(rig.sensors.size())) {
      throw make_error(origin(), "sensor",
                       "index " + std::to_string(sensor) + " is out of range (the rig has " +
                           std::to_string(rig.sensors.size()) + " sensors)");
    }
    return rig.sensors[sensor];
  }

  void check_depth_image(const ImageU16& depth, const SensorInfo& info, const std::string& what) const {
    check_frame_image(depth, 1, info, what);
  }

  // `channels` channels of the sensor's image size.
  template <typename T>
  void check_frame_image(const Image<T>& image, int channels, const SensorInfo& info, const std::string& what) const {
    check_image_shape(image, channels, origin(), info.name + " " + what);
    if (image.width != info.intrinsics.width || image.height != info.intrinsics.height) {
      throw make_error(origin(), info.name + " " + what + " size",
                       "expected " + size_text(info.intrinsics.width, info.intrinsics.height) + ", found " +
                           size_text(image.width, image.height));
    }
  }

  std::string reserve_timestamp(int sensor, double timestamp);
  void add_entry(int sensor, const std::string& timestamp_text, const std::string& rgb_file,
                 const std::string& depth_file);

  void create_directory(const fs::path& path) const {
    std::error_code ec;
    fs::create_directories(path, ec);
    if (ec) throw make_error(path.string(), "", "cannot create directory: " + ec.message());
  }
};

ScanWriter::ScanWriter(const fs::path& scan_dir, const RigInfo& rig, bool overwrite, int png_compression)
    : impl_(std::make_unique<Impl>()) {
  impl_->scan_dir = scan_dir;
  impl_->rig = rig;
  validate_rig(rig, (scan_dir / kRigFileName).string());
  if (png_compression < 0 || png_compression > 9) {
    throw make_error(scan_dir.string(), "png_compression",
                     "expected an integer in [0, 9], found " + std::to_string(png_compression));
  }
  impl_->png_compression = png_compression;
  try {
    impl_->directory = std::make_unique<AtomicDirectory>(scan_dir, overwrite);
  } catch (const fs::filesystem_error& e) {
    throw make_error(scan_dir.string(), "", std::string("cannot create the scan directory: ") + e.what());
  }
  impl_->create_directory(impl_->directory->temp_path());
  for (const SensorInfo& sensor : rig.sensors) {
    impl_->create_directory(impl_->directory->temp_path() / sensor.name / "rgb");
    impl_->create_directory(impl_->directory->temp_path() / sensor.name / "depth");
  }
  impl_->sensors.resize(rig.sensors.size());
}

ScanWriter::~ScanWriter() = default;  // AtomicDirectory removes the temporary directory unless committed

// Checks that `timestamp` may follow the sensor's last frame and reserves it; returns its 6-decimal
// text. Called with the mutex held.
std::string ScanWriter::Impl::reserve_timestamp(int sensor, double timestamp) {
  const SensorInfo& info = sensor_info(sensor);
  if (!std::isfinite(timestamp)) throw make_error(origin(), info.name, "frame timestamp is not finite");
  // The file name and the listing hold the timestamp with 6 decimals, so the ordering is
  // checked on that text: two frames 1e-7 s apart would otherwise share a file name.
  const std::string timestamp_text = format_timestamp(timestamp);
  const double written_timestamp = std::strtod(timestamp_text.c_str(), nullptr);
  SensorState& state = sensors[sensor];
  if (state.has_timestamp && !(written_timestamp > state.last_timestamp)) {
    throw make_error(origin(), info.name,
                     "frame timestamp " + timestamp_text + " does not increase (previous " +
                         format_timestamp(state.last_timestamp) +
                         "; frames of one sensor must arrive in time order, timestamps kept to 6 decimals)");
  }
  // Reserve the timestamp now so that the ordering holds even while the images are encoded.
  state.has_timestamp = true;
  state.last_timestamp = written_timestamp;
  return timestamp_text;
}

void ScanWriter::Impl::add_entry(int sensor, const std::string& timestamp_text, const std::string& rgb_file,
                                 const std::string& depth_file) {
  FrameEntry entry;
  entry.timestamp = std::strtod(timestamp_text.c_str(), nullptr);
  entry.rgb_file = rgb_file;
  entry.depth_file = depth_file;
  sensors[sensor].frames.push_back(std::move(entry));
}

void ScanWriter::write_frame(int sensor, double timestamp, const ImageU8& rgb, const ImageU16& depth) {
  std::string timestamp_text;
  fs::path camera_dir;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    check_image_shape(rgb, 3, impl_->origin(), info.name + " rgb image");
    if (rgb.width != info.intrinsics.width || rgb.height != info.intrinsics.height) {
      throw make_error(impl_->origin(), info.name + " rgb image size",
                       "expected " + size_text(info.intrinsics.width, info.intrinsics.height) + ", found " +
                           size_text(rgb.width, rgb.height));
    }
    impl_->check_depth_image(depth, info, "depth image");
    timestamp_text = impl_->reserve_timestamp(sensor, timestamp);
    camera_dir = impl_->directory->temp_path() / info.name;
  }
  const std::string rgb_file = "rgb/" + timestamp_text + ".png";
  const std::string depth_file = "depth/" + timestamp_text + ".png";
  write_png(camera_dir / rgb_file, rgb, impl_->png_compression);
  write_png16(camera_dir / depth_file, depth, impl_->png_compression);

  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->add_entry(sensor, timestamp_text, rgb_file, depth_file);
}

namespace {

// Width, height, bit depth and colour type from an encoded PNG's IHDR chunk; throws naming `what`.
void check_encoded_png(const std::string& png, const SensorInfo& info, int bit_depth, int colour_type,
                       const std::string& origin, const std::string& what) {
  const auto byte = [&](std::size_t at) { return std::uint32_t(static_cast<unsigned char>(png[at])); };
  const auto be32 = [&](std::size_t at) {
    return (byte(at) << 24) | (byte(at + 1) << 16) | (byte(at + 2) << 8) | byte(at + 3);
  };
  if (png.size() < 33 || png.compare(0, 8, "\x89PNG\r\n\x1a\n", 8) != 0 || png.compare(12, 4, "IHDR") != 0)
    throw make_error(origin, info.name + " " + what, "not an encoded PNG");
  if (be32(16) != std::uint32_t(info.intrinsics.width) || be32(20) != std::uint32_t(info.intrinsics.height))
    throw make_error(origin, info.name + " " + what + " size",
                     "expected " + size_text(info.intrinsics.width, info.intrinsics.height) + ", found " +
                         size_text(int(be32(16)), int(be32(20))));
  if (int(byte(24)) != bit_depth || int(byte(25)) != colour_type)
    throw make_error(origin, info.name + " " + what,
                     "wrong sample format (bit depth " + std::to_string(byte(24)) + ", colour type " +
                         std::to_string(byte(25)) + ")");
}

}  // namespace

void ScanWriter::write_encoded_frame(int sensor, double timestamp, const std::string& rgb_png,
                                     const std::string& depth_png) {
  std::string timestamp_text;
  fs::path camera_dir;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    check_encoded_png(rgb_png, info, 8, 2, impl_->origin(), "rgb image");
    check_encoded_png(depth_png, info, 16, 0, impl_->origin(), "depth image");
    timestamp_text = impl_->reserve_timestamp(sensor, timestamp);
    camera_dir = impl_->directory->temp_path() / info.name;
  }
  const std::string rgb_file = "rgb/" + timestamp_text + ".png";
  const std::string depth_file = "depth/" + timestamp_text + ".png";
  write_file_atomic(camera_dir / rgb_file, rgb_png);
  write_file_atomic(camera_dir / depth_file, depth_png);
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->add_entry(sensor, timestamp_text, rgb_file, depth_file);
}

void ScanWriter::add_frame_files(int sensor, double timestamp, const fs::path& rgb_source, const fs::path& depth_source,
                                 FileTransfer transfer) {
  std::string timestamp_text;
  fs::path camera_dir;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    timestamp_text = impl_->reserve_timestamp(sensor, timestamp);
    camera_dir = impl_->directory->temp_path() / impl_->rig.sensors[sensor].name;
  }
  std::string rgb_extension = rgb_source.extension().string();
  const bool plain_extension = rgb_extension.size() >= 2 && rgb_extension.size() <= 6 &&
                               std::all_of(rgb_extension.begin() + 1, rgb_extension.end(), [](char c) {
                                 return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
                               });
  if (!plain_extension) rgb_extension = ".png";
  const std::string rgb_file = "rgb/" + timestamp_text + rgb_extension;
  const std::string depth_file = "depth/" + timestamp_text + ".png";
  auto transfer_file = [&](const fs::path& source, const std::string& file) {
    const fs::path destination = camera_dir / file;
    std::error_code ec;
    if (transfer == FileTransfer::kHardLink) {
      fs::create_hard_link(source, destination, ec);
      if (ec) {
        throw make_error(source.string(), "",
                         "cannot hard-link into " + impl_->origin() + ": " + ec.message() +
                             " (another file system? import without hard links to copy)");
      }
    } else {
      fs::copy_file(source, destination, fs::copy_options::overwrite_existing, ec);
      if (ec) throw make_error(source.string(), "", "cannot copy into " + impl_->origin() + ": " + ec.message());
    }
  };
  transfer_file(rgb_source, rgb_file);
  transfer_file(depth_source, depth_file);
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->add_entry(sensor, timestamp_text, rgb_file, depth_file);
}

void ScanWriter::write_clean_depth(int sensor, double timestamp, const ImageU16& depth) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    if (!std::isfinite(timestamp)) throw make_error(impl_->origin(), info.name, "clean depth timestamp is not finite");
    impl_->check_depth_image(depth, info, "clean depth image");
    const fs::path directory = impl_->directory->temp_path() / kGroundtruthDirName / kCleanDepthDirName / info.name;
    impl_->create_directory(directory);
    path = directory / (format_timestamp(timestamp) + ".png");
  }
  write_png16(path, depth, impl_->png_compression);
}

void ScanWriter::write_groundtruth_normals(int sensor, double timestamp, const ImageF32& normal_cam) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    if (!std::isfinite(timestamp)) throw make_error(impl_->origin(), info.name, "normals timestamp is not finite");
    impl_->check_frame_image(normal_cam, 3, info, "normal image");
    path = groundtruth_normals_path(impl_->directory->temp_path(), info.name, timestamp);
    impl_->create_directory(path.parent_path());
  }
  write_exr(path, normal_cam, normal_channels());
}

void ScanWriter::write_groundtruth_ids(int sensor, double timestamp, const ImageI32& triangle_id,
                                       const ImageI32& material_id) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    if (!std::isfinite(timestamp)) throw make_error(impl_->origin(), info.name, "ids timestamp is not finite");
    impl_->check_frame_image(triangle_id, 1, info, "triangle id image");
    impl_->check_frame_image(material_id, 1, info, "material id image");
    path = groundtruth_ids_path(impl_->directory->temp_path(), info.name, timestamp);
    impl_->create_directory(path.parent_path());
  }
  // One file with both channels: a pixel's triangle and material stay together.
  ImageI32 ids(triangle_id.width, triangle_id.height, 2);
  for (std::size_t i = 0; i < triangle_id.data.size(); ++i) {
    ids.data[2 * i] = triangle_id.data[i];
    ids.data[2 * i + 1] = material_id.data[i];
  }
  write_exr_i32(path, ids, id_channels());
}

void ScanWriter::write_groundtruth_trajectory(int sensor, const std::vector<StampedPose>& poses) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const SensorInfo& info = impl_->sensor_info(sensor);
    const fs::path directory = impl_->directory->temp_path() / kGroundtruthDirName;
    impl_->create_directory(directory);
    path = directory / (info.name + ".txt");
  }
  write_tum_trajectory(path, poses);
}

void ScanWriter::write_groundtruth_file(const std::string& name, const std::string& bytes) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    if (!is_safe_relative_path(name)) {
      throw make_error(impl_->origin(), "groundtruth file",
                       "'" + name + "' must be a relative path inside " + std::string(kGroundtruthDirName) + "/");
    }
    path = impl_->directory->temp_path() / kGroundtruthDirName / name;
    impl_->create_directory(path.parent_path());
  }
  write_file_atomic(path, bytes);
}

void ScanWriter::write_groundtruth_mesh(const TriangleMesh& mesh) {
  fs::path path;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->check_not_committed();
    const fs::path directory = impl_->directory->temp_path() / kGroundtruthDirName;
    impl_->create_directory(directory);
    path = directory / "mesh.ply";
  }
  write_ply_mesh(path, mesh);
}

fs::path ScanWriter::temp_path(const std::string& relative) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->check_not_committed();
  if (!is_safe_relative_path(relative)) {
    throw make_error(impl_->origin(), "temp_path", "'" + relative + "' must be a relative path inside the scan");
  }
  const fs::path path = impl_->directory->temp_path() / relative;
  // Callers write the file themselves; make sure its folder exists so they need not know the layout.
  impl_->create_directory(path.parent_path());
  return path;
}

void ScanWriter::commit() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->check_not_committed();
  const fs::path root = impl_->directory->temp_path();
  for (std::size_t s = 0; s < impl_->rig.sensors.size(); ++s) {
    const SensorInfo& info = impl_->rig.sensors[s];
    std::vector<FrameEntry> frames = impl_->sensors[s].frames;
    // The reader refuses a camera without frames, so the writer does not produce one.
    if (frames.empty()) throw make_error(impl_->origin(), info.name, "no frames were written for this sensor");
    std::sort(frames.begin(), frames.end(),
              [](const FrameEntry& a, const FrameEntry& b) { return a.timestamp < b.timestamp; });
    std::string rgb_listing = kListingHeader;
    std::string depth_listing = kListingHeader;
    for (const FrameEntry& frame : frames) {
      const std::string timestamp_text = format_timestamp(frame.timestamp);
      rgb_listing += timestamp_text + " " + frame.rgb_file + "\n";
      depth_listing += timestamp_text + " " + frame.depth_file + "\n";
    }
    write_file_atomic(root / info.name / "rgb.txt", rgb_listing);
    write_file_atomic(root / info.name / "depth.txt", depth_listing);
  }
  write_file_atomic(root / kRigFileName, rig_to_json(impl_->rig));
  impl_->directory->commit();
  impl_->committed = true;
}

}  // namespace panoscan
