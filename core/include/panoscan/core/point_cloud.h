// Point clouds: the output of reconstruction (docs/ARCHITECTURE.md §11.3: PLY with colour and
// per-point variance) and the input of evaluation.
//
// PLY layout read and written here, one `vertex` element:
//   x y z        required; any numeric type (float or double in practice), metres
//   nx ny nz     optional, all three or none; float or double
//   red green blue  optional, all three or none; uchar (uint8)
//   variance     optional; float or double, m^2 (the panorama depth variance sigma_z^2), >= 0
// Other vertex properties and other elements (e.g. a mesh's faces) are skipped, so a mesh's PLY
// reads as the cloud of its vertices. The reader accepts ASCII and binary (little- or big-endian)
// files, through the one PLY header parser and body reader it shares with the mesh reader; the
// writer produces binary little-endian, atomically (temp file + rename). Point clouds of outside
// tools (PLY or PCD, with per-point uncertainty) are read for registration by cloud_file.h.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace panoscan {

using Rgb8 = std::array<std::uint8_t, 3>;

struct PointCloud {
  std::vector<Eigen::Vector3d> positions;  // metres
  std::vector<Eigen::Vector3f> normals;    // empty, or one unit normal per point
  std::vector<Rgb8> colours;               // empty, or one per point
  std::vector<float> variances;            // empty, or one per point (m^2)

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colours() const { return !colours.empty(); }
  bool has_variances() const { return !variances.empty(); }

  // Throws Error naming `origin` and the field if an optional array has the wrong length, a
  // position or normal is not finite, or a variance is negative or not finite.
  void check(const std::string& origin) const;
};

struct PlyWriteOptions {
  bool double_positions = false;      // x y z as double instead of float
  std::vector<std::string> comments;  // "comment ..." header lines (one line each, no newlines)
  // Extra per-point float properties (name, one value per point), e.g. ("distance", errors) so that
  // CloudCompare shows them as scalar fields.
  std::vector<std::pair<std::string, std::vector<float>>> extra_properties;
};

// Throws Error naming the file and the property or vertex on: a missing file, a header that is not
// PLY, no vertex element, a missing x/y/z, partial colour or normal triplets,
// colours that are not uchar, truncated data, non-finite coordinates, negative variances.
// A file with zero vertices reads as an empty cloud (callers decide whether that is an error).
PointCloud read_ply_point_cloud(const std::filesystem::path& path);

void write_ply_point_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                           const PlyWriteOptions& options = {});

}  // namespace panoscan
