// PLY point clouds (see point_cloud.h for the layout).
//
// The reader parses the header into elements and typed properties, then decodes the body with
// one generic value reader (ASCII tokens or little-endian bytes), so that elements before the
// vertex element (rare, but legal) are skipped correctly and every property type is accepted
// where it makes sense. Byte order is handled by explicit shifts, so the code does not depend
// on the host's endianness.

#include "panoscan/core/point_cloud.h"

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
using ply::type_size;

bool is_float_type(PlyType type) { return !ply::is_integer_type(type); }

// The shared header (ply_header.h); this reader decodes ASCII and little-endian bodies.
struct PlyHeader {
  bool ascii = false;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;
};

PlyHeader parse_header(const std::string& bytes, const std::string& file) {
  const ply::Header parsed = ply::parse_header(bytes, file);
  if (parsed.format == ply::Format::kBinaryBigEndian)
    throw make_error(file, "format", "binary_big_endian PLY is not supported (convert it to little-endian)");
  return {parsed.format == ply::Format::kAscii, parsed.elements, parsed.body_offset};
}

std::string read_whole_file(const std::filesystem::path& path) { return ply::read_whole_file(path.string()); }

// Reads values of the body one at a time, in either encoding. Throws a "truncated" Error naming
// the element and instance (set by the caller through `where`) when the data runs out.
class BodyReader {
 public:
  BodyReader(const std::string& bytes, std::size_t offset, bool ascii, std::string file)
      : bytes_(bytes), pos_(offset), ascii_(ascii), file_(std::move(file)) {}

  std::string where;  // e.g. "vertex 17"

  double value(PlyType type) { return ascii_ ? ascii_value() : binary_value(type); }

  std::size_t list_count(PlyType type) {
    const double count = value(type);
    if (!(count >= 0) || count != std::floor(count) || count > 1e9)
      throw make_error(file_, where, "invalid list length");
    return static_cast<std::size_t>(count);
  }

  std::size_t remaining_bytes() const { return bytes_.size() - pos_; }

 private:
  [[noreturn]] void truncated() const { throw make_error(file_, where, "file is truncated (data ends early)"); }

  double ascii_value() {
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (pos_ >= bytes_.size()) truncated();
    // bytes_ is a std::string, so its buffer is null-terminated and strtod stops at the end.
    const char* begin = bytes_.c_str() + pos_;
    char* end = nullptr;
    const double parsed = std::strtod(begin, &end);
    if (end == begin) {
      std::size_t token_end = pos_;
      while (token_end < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[token_end]))) ++token_end;
      throw make_error(file_, where,
                       "'" + bytes_.substr(pos_, std::min<std::size_t>(token_end - pos_, 40)) + "' is not a number");
    }
    pos_ += static_cast<std::size_t>(end - begin);
    return parsed;
  }

  std::uint64_t little_endian_bits(std::size_t size) {
    if (pos_ + size > bytes_.size()) truncated();
    std::uint64_t bits = 0;
    for (std::size_t k = 0; k < size; ++k)
      bits |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes_[pos_ + k])) << (8 * k);
    pos_ += size;
    return bits;
  }

  double binary_value(PlyType type) {
    const std::uint64_t bits = little_endian_bits(type_size(type));
    switch (type) {
      case PlyType::kInt8: return static_cast<std::int8_t>(bits);
      case PlyType::kUInt8: return static_cast<std::uint8_t>(bits);
      case PlyType::kInt16: return static_cast<std::int16_t>(bits);
      case PlyType::kUInt16: return static_cast<std::uint16_t>(bits);
      case PlyType::kInt32: return static_cast<std::int32_t>(bits);
      case PlyType::kUInt32: return static_cast<std::uint32_t>(bits);
      case PlyType::kFloat32: {
        const std::uint32_t narrow = static_cast<std::uint32_t>(bits);
        float f;
        std::memcpy(&f, &narrow, sizeof f);
        return f;
      }
      case PlyType::kFloat64: {
        double d;
        std::memcpy(&d, &bits, sizeof d);
        return d;
      }
    }
    return 0.0;
  }

  const std::string& bytes_;
  std::size_t pos_;
  bool ascii_;
  std::string file_;
};

void skip_element(BodyReader& reader, const PlyElement& element) {
  for (std::size_t i = 0; i < element.count; ++i) {
    reader.where = element.name + " " + std::to_string(i);
    for (const PlyProperty& property : element.properties) {
      if (property.is_list) {
        const std::size_t n = reader.list_count(property.count_type);
        for (std::size_t k = 0; k < n; ++k) reader.value(property.type);
      } else {
        reader.value(property.type);
      }
    }
  }
}

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

PointCloud read_ply_point_cloud(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string bytes = read_whole_file(path);
  const PlyHeader header = parse_header(bytes, file);

  int vertex_index = -1;
  for (std::size_t e = 0; e < header.elements.size(); ++e)
    if (header.elements[e].name == "vertex") {
      vertex_index = static_cast<int>(e);
      break;
    }
  if (vertex_index < 0) throw make_error(file, "element vertex", "the PLY file has no 'vertex' element");
  const PlyElement& vertex = header.elements[vertex_index];

  const auto xyz = find_triplet(vertex, {"x", "y", "z"}, true, file);
  const auto normal = find_triplet(vertex, {"nx", "ny", "nz"}, false, file);
  const auto rgb = find_triplet(vertex, {"red", "green", "blue"}, false, file);
  if (rgb)
    for (int k = 0; k < 3; ++k)
      if (vertex.properties[(*rgb)[k]].type != PlyType::kUInt8)
        throw make_error(file, "property " + vertex.properties[(*rgb)[k]].name, "colours must be uchar (0..255)");
  const int variance_index = find_property(vertex, "variance");
  if (variance_index >= 0 &&
      (vertex.properties[variance_index].is_list || !is_float_type(vertex.properties[variance_index].type)))
    throw make_error(file, "property variance", "must be a float or double scalar");

  BodyReader reader(bytes, header.body_offset, header.ascii, file);
  for (int e = 0; e < vertex_index; ++e) skip_element(reader, header.elements[e]);

  // Guard the allocation against a corrupt count: every vertex takes at least one byte per
  // property in either encoding.
  const std::size_t min_bytes_per_vertex = std::max<std::size_t>(1, vertex.properties.size());
  if (vertex.count > reader.remaining_bytes() / min_bytes_per_vertex + 1)
    throw make_error(file, "element vertex",
                     "declares " + std::to_string(vertex.count) + " vertices but the file is too short for them");

  PointCloud cloud;
  cloud.positions.resize(vertex.count);
  if (normal) cloud.normals.resize(vertex.count);
  if (rgb) cloud.colours.resize(vertex.count);
  if (variance_index >= 0) cloud.variances.resize(vertex.count);

  std::vector<double> values(vertex.properties.size());
  for (std::size_t i = 0; i < vertex.count; ++i) {
    reader.where = "vertex " + std::to_string(i);
    for (std::size_t p = 0; p < vertex.properties.size(); ++p) {
      const PlyProperty& property = vertex.properties[p];
      if (property.is_list) {
        const std::size_t n = reader.list_count(property.count_type);
        for (std::size_t k = 0; k < n; ++k) reader.value(property.type);
        values[p] = 0.0;
      } else {
        values[p] = reader.value(property.type);
      }
    }
    Eigen::Vector3d& position = cloud.positions[i];
    for (int k = 0; k < 3; ++k) {
      position[k] = values[(*xyz)[k]];
      if (!std::isfinite(position[k]))
        throw make_error(file, reader.where, "coordinate '" + vertex.properties[(*xyz)[k]].name + "' is not finite");
    }
    if (normal) {
      for (int k = 0; k < 3; ++k) cloud.normals[i][k] = static_cast<float>(values[(*normal)[k]]);
      if (!cloud.normals[i].allFinite()) throw make_error(file, reader.where, "normal is not finite");
    }
    if (rgb) {
      for (int k = 0; k < 3; ++k) {
        const double c = values[(*rgb)[k]];
        if (!(c >= 0 && c <= 255)) throw make_error(file, reader.where, "colour value out of range 0..255");
        cloud.colours[i][k] = static_cast<std::uint8_t>(c);
      }
    }
    if (variance_index >= 0) {
      const double variance = values[variance_index];
      if (!std::isfinite(variance) || variance < 0)
        throw make_error(file, reader.where, "variance must be finite and >= 0");
      cloud.variances[i] = static_cast<float>(variance);
    }
  }
  return cloud;
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
