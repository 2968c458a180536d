// Internal to panoscan_core: what the cloud readers (PLY in point_cloud_io.cpp, PCD in pcd_io.cpp)
// hand to read_cloud_file (cloud_file.cpp): the positions plus named per-point scalar columns.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/point_cloud.h"

namespace panoscan::detail {

struct PlyVertexRequest {
  // Read PointCloud's optional attributes (nx ny nz, red green blue, variance) with their checks;
  // false = positions only, every other property skipped by its declared type.
  bool attributes = true;
  // Points with a NaN coordinate are dropped (counted), not refused: outside tools mark the invalid
  // points of organised clouds that way. An infinite coordinate is still an Error.
  bool drop_nan_points = false;
  // Scalar vertex properties to return as columns when present (any numeric type).
  std::vector<std::string> extra;
};

struct PlyVertexExtras {
  std::vector<std::vector<double>> columns;  // one per requested name: empty when absent, else one per kept point
  std::string format;                        // "ply ascii", "ply binary_little_endian", ...
  std::uint64_t declared_points = 0;
  std::uint64_t dropped_invalid = 0;
  std::vector<std::uint64_t> kept;  // the vertex index in the file of each kept point (when columns were requested)
};

PointCloud read_ply_vertices(const std::filesystem::path& path, const PlyVertexRequest& request,
                             PlyVertexExtras* extras);

// A PCD file (pcd_io.cpp): the points (NaN points dropped) and the requested fields as columns.
struct PcdData {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<double>> columns;  // as PlyVertexExtras::columns
  std::string format;                        // "pcd ascii", "pcd binary", "pcd binary_compressed"
  std::uint64_t declared_points = 0;
  std::uint64_t dropped_invalid = 0;
  std::vector<std::uint64_t> kept;  // the point index in the file of each kept point
  std::uint64_t first_data_line = 0;  // ASCII: the file line of point 0 (1-based); 0 for binary
  bool has_viewpoint = false;  // a VIEWPOINT line
  Eigen::Vector3d viewpoint_translation = Eigen::Vector3d::Zero();
  Eigen::Vector4d viewpoint_quaternion_wxyz = Eigen::Vector4d(1, 0, 0, 0);
};

PcdData read_pcd(const std::filesystem::path& path, const std::vector<std::string>& extra);

}  // namespace panoscan::detail
