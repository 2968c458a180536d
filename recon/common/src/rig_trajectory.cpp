#include "panoscan/recon/rig_trajectory.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/version.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"

namespace fs = std::filesystem;

namespace panoscan {

namespace {}  // namespace

void check_rig_trajectory(const RigTrajectory& trajectory, const ScanIndex& scan, const std::string& origin) {
  const std::size_t sensors = scan.rig.sensors.size();
  if (trajectory.world_from_cam.size() != sensors)
    throw make_error(origin, "sensors",
                     "expected " + std::to_string(sensors) + " trajectories, found " +
                         std::to_string(trajectory.world_from_cam.size()));
  if (trajectory.ref_from_cam.size() != sensors)
    throw make_error(origin, "ref_from_cam", "expected " + std::to_string(sensors) + " extrinsics");
  for (std::size_t c = 0; c < sensors; ++c) {
    const auto& poses = trajectory.world_from_cam[c];
    const auto& frames = scan.frames[c];
    const std::string name = scan.rig.sensors[c].name;
    if (poses.size() != frames.size())
      throw make_error(
          origin, name,
          "expected one pose per frame (" + std::to_string(frames.size()) + "), found " + std::to_string(poses.size()));
    for (std::size_t i = 0; i < poses.size(); ++i) {
      if (std::abs(poses[i].timestamp - frames[i].timestamp) > 5e-7)
        throw make_error(origin, name + " pose " + std::to_string(i),
                         "timestamp " + format_timestamp(poses[i].timestamp) + " does not match the frame's " +
                             format_timestamp(frames[i].timestamp));
      if (!poses[i].world_from_cam.matrix().allFinite())
        throw make_error(origin, name + " pose " + std::to_string(i), "non-finite pose");
    }
  }
  if (!trajectory.world_from_axis.matrix().allFinite()) throw make_error(origin, "world_from_axis", "non-finite pose");
}

void write_rig_trajectory(const fs::path& dir, const RigTrajectory& trajectory, const RigInfo& rig) {
  if (trajectory.world_from_cam.size() != rig.sensors.size())
    throw make_error(dir.string(), "sensors", "trajectory and rig disagree on the number of sensors");
  for (std::size_t c = 0; c < rig.sensors.size(); ++c)
    write_tum_trajectory(dir / (rig.sensors[c].name + ".txt"), trajectory.world_from_cam[c]);
  nlohmann::json j;
  j["format"] = "panoscan-rig-trajectory";
  j["version"] = 1;
  j["source"] = trajectory.source;
  j["world_from_axis"] = pose_to_json(trajectory.world_from_axis);
  j["ref_from_cam"] = nlohmann::json::array();
  for (const Rigid3d& pose : trajectory.ref_from_cam) j["ref_from_cam"].push_back(pose_to_json(pose));
  j["written_by"] = {{"version", project_version()}, {"source_revision", source_revision()}};
  write_file_atomic(dir / "rig_estimate.json", j.dump(2) + "\n");
}

RigTrajectory read_rig_trajectory(const fs::path& dir, const ScanIndex& scan) {
  const fs::path json_path = dir / "rig_estimate.json";
  const nlohmann::json j = read_json_file(json_path, "not a rig trajectory folder?");
  // Checked field by field: a JSON value of another type must be an Error naming it, not a JSON
  // exception (found by fuzz/pose_fuzz.cpp).
  if (!j.is_object()) throw make_error(json_path.string(), "", "expected a JSON object");
  if (!j.contains("format") || j["format"] != "panoscan-rig-trajectory")
    throw make_error(json_path.string(), "format", "expected \"panoscan-rig-trajectory\"");
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"] != 1)
    throw make_error(json_path.string(), "version",
                     "expected 1, found " + (j.contains("version") ? j["version"].dump() : std::string("nothing")));
  RigTrajectory trajectory;
  if (j.contains("source")) {
    if (!j["source"].is_string()) throw make_error(json_path.string(), "source", "expected a string");
    trajectory.source = j["source"].get<std::string>();
  }
  if (!j.contains("world_from_axis")) throw make_error(json_path.string(), "world_from_axis", "missing field");
  trajectory.world_from_axis = pose_from_json(j["world_from_axis"], json_path.string(), "world_from_axis");
  if (!j.contains("ref_from_cam") || !j["ref_from_cam"].is_array())
    throw make_error(json_path.string(), "ref_from_cam", "missing list");
  for (std::size_t c = 0; c < j["ref_from_cam"].size(); ++c)
    trajectory.ref_from_cam.push_back(
        pose_from_json(j["ref_from_cam"][c], json_path.string(), "ref_from_cam[" + std::to_string(c) + "]"));
  for (const SensorInfo& sensor : scan.rig.sensors)
    trajectory.world_from_cam.push_back(read_tum_trajectory(dir / (sensor.name + ".txt")));
  check_rig_trajectory(trajectory, scan, dir.string());
  return trajectory;
}

Rigid3d axis_frame(const Eigen::Vector3d& axis_point, const Eigen::Vector3d& axis_direction,
                   const Rigid3d& world_from_reference_cam) {
  const Eigen::Vector3d z = axis_direction.normalized();
  const Eigen::Vector3d centre = world_from_reference_cam.translation();
  const Eigen::Vector3d origin = axis_point + (centre - axis_point).dot(z) * z;
  Eigen::Vector3d x = world_from_reference_cam.linear().col(2);  // optical axis
  x -= x.dot(z) * z;
  if (x.norm() < 1e-9) x = z.unitOrthogonal();  // camera looking along the axis
  x.normalize();
  Eigen::Matrix3d rotation;
  rotation.col(0) = x;
  rotation.col(1) = z.cross(x);
  rotation.col(2) = z;
  return make_rigid(rotation, origin);
}

}  // namespace panoscan
