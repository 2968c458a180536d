#include "panoscan/eval/groundtruth.h"

#include <fstream>

#include <nlohmann/json.hpp>

#include "panoscan/core/pose_json.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/scan.h"

namespace fs = std::filesystem;

namespace panoscan::eval {

namespace {

Eigen::Vector3d vector_field(const nlohmann::json& j, const std::string& file, const std::string& field) {
  if (!j.is_array() || j.size() != 3) throw make_error(file, field, "expected 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

}  // namespace

Rigid3d scene_from_reconstruction(const std::vector<StampedPose>& true_poses,
                                  const std::vector<StampedPose>& reconstructed_poses) {
  if (true_poses.empty() || reconstructed_poses.empty())
    throw make_error("", "poses", "the scene alignment needs a first true and a first reconstructed pose");
  return true_poses.front().world_from_cam * reconstructed_poses.front().world_from_cam.inverse();
}

RigTrajectory groundtruth_rig_trajectory(const fs::path& scan_dir) {
  const ScanIndex scan = read_scan_index(scan_dir);
  const fs::path truth_path = groundtruth_dir(scan_dir) / "rig_truth.json";
  const nlohmann::json truth = read_json_file(truth_path, "not a simulated scan?");
  const std::string file = truth_path.string();
  try {
    RigTrajectory trajectory;
    trajectory.source = "groundtruth";
    for (std::size_t c = 0; c < scan.rig.sensors.size(); ++c)
      trajectory.world_from_cam.push_back(read_groundtruth_trajectory(scan_dir, int(c)));
    const auto& sensors = truth.at("sensors");
    if (sensors.size() != scan.rig.sensors.size())
      throw make_error(file, "sensors", "does not match rig.json's sensor count");
    for (std::size_t c = 0; c < sensors.size(); ++c)
      trajectory.ref_from_cam.push_back(pose_from_json(sensors[c].at("ref_from_cam_true"), file,
                                                       "sensors[" + std::to_string(c) + "].ref_from_cam_true"));
    const int reference = scan.rig.reference_sensor;
    if (trajectory.world_from_cam[reference].empty()) throw make_error(file, "reference sensor", "has no frames");
    trajectory.world_from_axis = axis_frame(vector_field(truth.at("axis").at("point"), file, "axis.point"),
                                            vector_field(truth.at("axis").at("direction"), file, "axis.direction"),
                                            trajectory.world_from_cam[reference].front().world_from_cam);
    check_rig_trajectory(trajectory, scan, groundtruth_dir(scan_dir).string());
    return trajectory;
  } catch (const nlohmann::json::exception& e) {
    throw make_error(file, "", std::string("missing or mistyped field: ") + e.what());
  }
}

}  // namespace panoscan::eval
