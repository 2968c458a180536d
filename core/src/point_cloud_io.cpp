// PLY point clouds (see point_cloud.h for the layout).
//
// The reader parses the header into elements and typed properties (ply_header.h), then decodes
// the body with the one PLY value reader (ply::BodyReader: ASCII tokens, binary of either byte
// order), so that elements before the vertex element (rare, but legal) are skipped correctly and
// every property type is accepted where it makes sense. read_cloud_file (cloud_file.h) reads a
// PLY through the same function, asking for its uncertainty properties as extra columns.

#include "panoscan/core/point_cloud.h"

#include "cloud_columns.h"
#include "ply_header.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"

namespace panoscan {

void PointCloud::check(const std::string& origin) const {
  const std::size_t n = positions.size();
  if (!normals.empty() && normals.size() != n)
    throw make_error(origin, "normals",
                     std::to_string(normals.size()) + " normals for " + std::to_string(n) + " points");
  if (!colours.empty() && colours.size() != n)
    throw make_error(origin, "colours",
                     std::to_string(colours.size()) + " colours for " + std::to_string(n) + " points");
  if (!variances.empty() && variances.size() != n)
    throw make_error(origin, "variances",
                     std::to_string(variances.size()) + " variances for " + std::to_string(n) + " points");
  for (std::size_t i = 0; i < n; ++i)
    if (!positions[i].allFinite()) throw make_error(origin, "point " + std::to_string(i), "non-finite coordinate");
  for (std::size_t i = 0; i < normals.size(); ++i)
    if (!normals[i].allFinite()) throw make_error(origin, "point " + std::to_string(i), "non-finite normal");
  for (std::size_t i = 0; i < variances.size(); ++i)
    if (!std::isfinite(variances[i]) || variances[i] < 0.f)
      throw make_error(origin, "point " + std::to_string(i), "variance must be finite and >= 0");
}

namespace {

using PlyType = ply::Type;
using PlyProperty = ply::Property;
using PlyElement = ply::Element;

bool is_float_type(PlyType type) { return !ply::is_integer_type(type); }

// Index of the property called `name` in the element, or -1.
int find_property(const PlyElement& element, const std::string& name) {
  for (std::size_t i = 0; i < element.properties.size(); ++i)
    if (element.properties[i].name == name) return static_cast<int>(i);
  return -1;
}

// Indices of a triplet that must be complete if present at all (x y z, nx ny nz, red green blue).
std::optional<std::array<int, 3>> find_triplet(const PlyElement& vertex, const std::array<const char*, 3>& names,
                                               bool required, const std::string& file) {
  std::array<int, 3> indices{};
  int found = 0;
  for (int k = 0; k < 3; ++k) {
    indices[k] = find_property(vertex, names[k]);
    if (indices[k] >= 0) ++found;
  }
  if (found == 0 && !required) return std::nullopt;
  for (int k = 0; k < 3; ++k) {
    if (indices[k] < 0) {
      const std::string all = std::string(names[0]) + ", " + names[1] + " and " + names[2];
      throw make_error(file, std::string("property ") + names[k],
                       "missing from element 'vertex' (" + all + (required ? " are required)" : " go together)"));
    }
    if (vertex.properties[indices[k]].is_list)
      throw make_error(file, std::string("property ") + names[k], "must be a scalar, not a list");
  }
  return indices;
}

void append_le(std::string& out, const void* value, std::size_t size) {
  // Byte order by value, independent of the host: reinterpret as an unsigned integer and shift.
  std::uint64_t bits = 0;
  std::memcpy(&bits, value, size);
  for (std::size_t k = 0; k < size; ++k) out.push_back(static_cast<char>((bits >> (8 * k)) & 0xFF));
}

void append_f32(std::string& out, float value) { append_le(out, &value, 4); }
void append_f64(std::string& out, double value) { append_le(out, &value, 8); }

}  // namespace

namespace detail {

PointCloud read_ply_vertices(const std::filesystem::path& path, const PlyVertexRequest& request,
                             PlyVertexExtras* extras) {
  const std::string file = path.string();
  const std::string bytes = ply::read_whole_file(file);
  const ply::Header header = ply::parse_header(bytes, file);

  int vertex_index = -1;
  for (std::size_t e = 0; e < header.elements.size(); ++e)
    if (header.elements[e].name == "vertex") {
      vertex_index = static_cast<int>(e);
      break;
    }
  if (vertex_index < 0) throw make_error(file, "element vertex", "the PLY file has no 'vertex' element");
  const PlyElement& vertex = header.elements[vertex_index];

  const auto xyz = find_triplet(vertex, {"x", "y", "z"}, true, file);
  std::optional<std::array<int, 3>> normal, rgb;
  int variance_index = -1;
  if (request.attributes) {
    normal = find_triplet(vertex, {"nx", "ny", "nz"}, false, file);
    rgb = find_triplet(vertex, {"red", "green", "blue"}, false, file);
    if (rgb)
      for (int k = 0; k < 3; ++k)
        if (vertex.properties[(*rgb)[k]].type != PlyType::kUInt8)
          throw make_error(file, "property " + vertex.properties[(*rgb)[k]].name, "colours must be uchar (0..255)");
    variance_index = find_property(vertex, "variance");
    if (variance_index >= 0 &&
        (vertex.properties[variance_index].is_list || !is_float_type(vertex.properties[variance_index].type)))
      throw make_error(file, "property variance", "must be a float or double scalar");
  }
  std::vector<int> extra_index(request.extra.size(), -1);
  if (extras) {
    extras->columns.assign(request.extra.size(), {});
    extras->format = header.format == ply::Format::kAscii                ? "ply ascii"
                     : header.format == ply::Format::kBinaryLittleEndian ? "ply binary_little_endian"
                                                                         : "ply binary_big_endian";
    extras->declared_points = vertex.count;
    extras->dropped_invalid = 0;
    extras->kept.clear();
  }
  for (std::size_t k = 0; k < request.extra.size(); ++k) {
    extra_index[k] = find_property(vertex, request.extra[k]);
    if (extra_index[k] >= 0 && vertex.properties[extra_index[k]].is_list)
      throw make_error(file, "property " + request.extra[k], "must be a scalar, not a list");
  }

  ply::BodyReader reader(bytes, header, file);
  for (int e = 0; e < vertex_index; ++e) reader.skip_element(header.elements[e]);

  // Guard the allocation against a corrupt count: every vertex takes at least one byte per
  // property in either encoding.
  const std::uint64_t min_bytes_per_vertex = std::max<std::size_t>(1, vertex.properties.size());
  if (vertex.count > reader.remaining() / min_bytes_per_vertex + 1)
    throw make_error(file, "element vertex",
                     "declares " + std::to_string(vertex.count) + " vertices but the file is too short for them");

  PointCloud cloud;
  cloud.positions.reserve(vertex.count);
  if (normal) cloud.normals.reserve(vertex.count);
  if (rgb) cloud.colours.reserve(vertex.count);
  if (variance_index >= 0) cloud.variances.reserve(vertex.count);
  if (extras)
    for (std::size_t k = 0; k < request.extra.size(); ++k)
      if (extra_index[k] >= 0) extras->columns[k].reserve(vertex.count);

  std::vector<double> values(vertex.properties.size());
  for (std::uint64_t i = 0; i < vertex.count; ++i) {
    reader.at(vertex.name, i);
    for (std::size_t p = 0; p < vertex.properties.size(); ++p) {
      const PlyProperty& property = vertex.properties[p];
      if (property.is_list) {
        const std::size_t n = reader.list_length(property.count_type, property.name);
        for (std::size_t k = 0; k < n; ++k) reader.skip(property.type, property.name);
        values[p] = 0.0;
      } else {
        values[p] = reader.read(property.type, property.name);
      }
    }
    Eigen::Vector3d position;
    for (int k = 0; k < 3; ++k) position[k] = values[(*xyz)[k]];
    if (!position.allFinite()) {
      // Cloud files of outside tools mark invalid points (of organised clouds) by NaN.
      if (request.drop_nan_points && position.array().isNaN().any()) {
        if (extras) ++extras->dropped_invalid;
        continue;
      }
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(position[k]))
          throw make_error(file, reader.where(), "coordinate '" + vertex.properties[(*xyz)[k]].name + "' is not finite");
    }
    cloud.positions.push_back(position);
    if (normal) {
      Eigen::Vector3f n;
      for (int k = 0; k < 3; ++k) n[k] = static_cast<float>(values[(*normal)[k]]);
      if (!n.allFinite()) throw make_error(file, reader.where(), "normal is not finite");
      cloud.normals.push_back(n);
    }
    if (rgb) {
      Rgb8 colour;
      for (int k = 0; k < 3; ++k) {
        const double c = values[(*rgb)[k]];
        if (!(c >= 0 && c <= 255)) throw make_error(file, reader.where(), "colour value out of range 0..255");
        colour[k] = static_cast<std::uint8_t>(c);
      }
      cloud.colours.push_back(colour);
    }
    if (variance_index >= 0) {
      const double variance = values[variance_index];
      if (!std::isfinite(variance) || variance < 0)
        throw make_error(file, reader.where(), "variance must be finite and >= 0");
      cloud.variances.push_back(static_cast<float>(variance));
    }
    if (extras) {
      extras->kept.push_back(i);
      for (std::size_t k = 0; k < request.extra.size(); ++k)
        if (extra_index[k] >= 0) extras->columns[k].push_back(values[extra_index[k]]);
    }
  }
  return cloud;
}

}  // namespace detail

PointCloud read_ply_point_cloud(const std::filesystem::path& path) {
  return detail::read_ply_vertices(path, detail::PlyVertexRequest{}, nullptr);
}

void write_ply_point_cloud(const std::filesystem::path& path, const PointCloud& cloud, const PlyWriteOptions& options) {
  const std::string file = path.string();
  cloud.check(file);
  for (const auto& comment : options.comments)
    if (comment.find_first_of("\r\n") != std::string::npos)
      throw make_error(file, "comment", "a PLY comment must be a single line");
  for (const auto& [name, values] : options.extra_properties) {
    if (name.empty() || name.find_first_of(" \t\r\n") != std::string::npos)
      throw make_error(file, "property '" + name + "'", "property names must be one word");
    if (values.size() != cloud.size())
      throw make_error(file, "property " + name,
                       std::to_string(values.size()) + " values for " + std::to_string(cloud.size()) + " points");
  }

  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by PanoScan\n";
  for (const auto& comment : options.comments) out += "comment " + comment + "\n";
  out += "element vertex " + std::to_string(cloud.size()) + "\n";
  const char* position_type = options.double_positions ? "double" : "float";
  for (const char* axis : {"x", "y", "z"}) out += std::string("property ") + position_type + " " + axis + "\n";
  if (cloud.has_normals()) out += "property float nx\nproperty float ny\nproperty float nz\n";
  if (cloud.has_colours()) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (cloud.has_variances()) out += "property float variance\n";
  for (const auto& extra : options.extra_properties) out += "property float " + extra.first + "\n";
  out += "end_header\n";

  const std::size_t bytes_per_point = (options.double_positions ? 24 : 12) + (cloud.has_normals() ? 12 : 0) +
                                      (cloud.has_colours() ? 3 : 0) + (cloud.has_variances() ? 4 : 0) +
                                      4 * options.extra_properties.size();
  out.reserve(out.size() + bytes_per_point * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (options.double_positions)
        append_f64(out, cloud.positions[i][k]);
      else
        append_f32(out, static_cast<float>(cloud.positions[i][k]));
    }
    if (cloud.has_normals())
      for (int k = 0; k < 3; ++k) append_f32(out, cloud.normals[i][k]);
    if (cloud.has_colours())
      for (int k = 0; k < 3; ++k) out.push_back(static_cast<char>(cloud.colours[i][k]));
    if (cloud.has_variances()) append_f32(out, cloud.variances[i]);
    for (const auto& extra : options.extra_properties) append_f32(out, extra.second[i]);
  }
  write_file_atomic(path, out);
}

}  // namespace panoscan
