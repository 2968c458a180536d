// Point-cloud files of outside tools, as `recon register` reads them (docs/ARCHITECTURE.md §10.4):
// PLY (ASCII, binary little- or big-endian; through the one PLY reader of point_cloud.h) and PCD
// (PCL's format v0.5-0.7: DATA ascii, binary and binary_compressed), chosen by the extension.
//
// Read: the positions x y z (metres, any numeric type; other properties, fields and elements such
// as range grids, faces, normals, colour or intensity are skipped by their declared types), and the
// per-point uncertainty when the file carries it, under these names (the first present wins):
//   cov_xx cov_xy cov_xz cov_yy cov_yz cov_zz   the full covariance, upper triangle (m^2); all six
//                                                or none; must be symmetric positive semi-definite
//   variance                                     an isotropic variance (m^2): covariance variance * I
//   sigma                                        an isotropic standard deviation (m): sigma^2 * I
// Points with a NaN coordinate are invalid markers of organised clouds (PCL, scanners) and are
// dropped and counted; an infinite coordinate, a non-finite or negative uncertainty is an Error.
// PCD's VIEWPOINT (tx ty tz qw qx qy qz) is the sensor pose in the cloud's frame; its translation
// is the sensor origin.
//
// Every refusal is an Error naming the file and the field, line or point: a missing file, an
// unknown extension, a malformed header, missing x/y/z, counts that disagree (SIZE/TYPE/COUNT
// against FIELDS, POINTS against WIDTH*HEIGHT, an ASCII line with the wrong number of values),
// truncated data, a value that is not a number (or not an integer for an integer type).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace panoscan {

struct CloudFile {
  std::string path;
  std::string format;                        // "ply ascii", "ply binary_big_endian", "pcd binary_compressed", ...
  std::vector<Eigen::Vector3d> points;       // metres, in the file's frame
  std::vector<Eigen::Matrix3d> covariances;  // empty, or one per point (m^2)
  std::string uncertainty;                   // where covariances came from: "cov_xx..cov_zz", "variance", "sigma", or ""
  std::uint64_t declared_points = 0;         // as the header says
  std::uint64_t dropped_invalid = 0;         // NaN points dropped
  bool has_viewpoint = false;                // PCD: a VIEWPOINT line
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();  // its translation (the sensor origin)
};

// True for a path ending in .ply or .pcd (case-insensitive).
bool is_cloud_file_path(const std::filesystem::path& path);

// Reads a .ply or .pcd file (see above). Throws Error naming the file for anything it refuses.
CloudFile read_cloud_file(const std::filesystem::path& path);

}  // namespace panoscan
