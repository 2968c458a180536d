// How every PanoScan JSON file stores a pose:
//   {"translation": [x, y, z], "rotation_quaternion_xyzw": [qx, qy, qz, qw]}
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "panoscan/core/geometry.h"

namespace panoscan {

nlohmann::json pose_to_json(const Rigid3d& pose);

// Validates: an object with exactly those two fields, 3 and 4 finite numbers, a unit quaternion
// (within 1e-6). Throws Error naming `file` and `field` (e.g. "sensors[1].ref_from_cam").
Rigid3d pose_from_json(const nlohmann::json& object, const std::string& file, const std::string& field);

// A pose file: one pose object as above, or an object whose "target_from_source" is one (an output
// of `recon register`). Throws Error naming the file and the field.
Rigid3d read_pose_file(const std::filesystem::path& path);

}  // namespace panoscan
