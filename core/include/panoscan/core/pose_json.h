// How every PanoScan JSON file stores a pose:
//   {"translation": [x, y, z], "rotation_quaternion_xyzw": [qx, qy, qz, qw]}
// and its 4x4 text form for outside tools (CloudCompare, Open3D, numpy.loadtxt): four lines of four
// numbers, the homogeneous matrix [R t; 0 0 0 1] (metres).
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
// of `recon register`); or, for a path ending in .txt, a 4x4 matrix as pose_matrix_text writes it
// ('#' starts a comment; the last row must be 0 0 0 1 and R a rotation, both within 1e-6; R is
// then re-orthonormalised). Throws Error naming the file and the field or line.
Rigid3d read_pose_file(const std::filesystem::path& path);

// The 4x4 text form: four lines "r00 r01 r02 tx" ... "0 0 0 1", 17 significant digits.
std::string pose_matrix_text(const Rigid3d& pose);

}  // namespace panoscan
