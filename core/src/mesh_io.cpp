// PLY meshes (Turk's polygon file format): a header of elements with typed properties, then the
// data in ASCII or binary. We write binary little-endian with float x y z and uchar/int faces, and
// read ASCII and binary (either byte order), skipping every element and property we do not need.
#include "panoscan/core/mesh_io.h"

#include "ply_header.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"

namespace fs = std::filesystem;

namespace panoscan {

namespace {

bool host_is_little_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

template <typename T>
void append_little_endian(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (!host_is_little_endian())
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  out.append(bytes, sizeof(T));
}

// ------------------------------------------------------------------------------------------------
// Header model.

using PlyType = ply::Type;
using PlyProperty = ply::Property;
using PlyElement = ply::Element;
using ply::is_integer_type;

// A colour channel of this type maps [0, colour_scale] to [0, 1].
double colour_scale(PlyType type) {
  switch (type) {
    case PlyType::kInt8: return 127.0;
    case PlyType::kUInt8: return 255.0;
    case PlyType::kInt16: return 32767.0;
    case PlyType::kUInt16: return 65535.0;
    case PlyType::kInt32: return 2147483647.0;
    case PlyType::kUInt32: return 4294967295.0;
    default: return 1.0;
  }
}

}  // namespace

void write_ply_mesh(const fs::path& path, const TriangleMesh& mesh) {
  const std::string file = path.string();
  const std::size_t num_vertices = mesh.vertices.size();
  if (num_vertices > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    throw make_error(file, "vertices", "too many vertices for int32 face indices");
  for (std::size_t i = 0; i < num_vertices; ++i)
    if (!mesh.vertices[i].allFinite()) throw make_error(file, "vertex " + std::to_string(i), "non-finite coordinate");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int index = mesh.triangles[t][k];
      if (index < 0 || static_cast<std::size_t>(index) >= num_vertices)
        throw make_error(file, "face " + std::to_string(t), "vertex index " + std::to_string(index) + " out of range");
    }

  const bool coloured = !mesh.vertex_colours.empty();
  if (coloured && mesh.vertex_colours.size() != num_vertices)
    throw make_error(file, "vertex colours", "expected one per vertex");
  std::string bytes = "ply\nformat binary_little_endian 1.0\ncomment PanoScan mesh (metres)\n";
  bytes += "element vertex " + std::to_string(num_vertices) + "\n";
  bytes += "property float x\nproperty float y\nproperty float z\n";
  if (coloured) bytes += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  bytes += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  bytes += "property list uchar int vertex_indices\nend_header\n";
  bytes.reserve(bytes.size() + num_vertices * (coloured ? 15 : 12) + mesh.triangles.size() * 13);
  for (std::size_t i = 0; i < num_vertices; ++i) {
    const Eigen::Vector3f& v = mesh.vertices[i];
    append_little_endian(bytes, v.x());
    append_little_endian(bytes, v.y());
    append_little_endian(bytes, v.z());
    if (coloured)
      for (int c = 0; c < 3; ++c) {
        const float value = mesh.vertex_colours[i][c];
        if (!std::isfinite(value)) throw make_error(file, "vertex colour " + std::to_string(i), "not finite");
        append_little_endian(bytes, static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.f, 1.f) * 255.f)));
      }
  }
  for (const Eigen::Vector3i& triangle : mesh.triangles) {
    append_little_endian(bytes, std::uint8_t{3});
    for (int k = 0; k < 3; ++k) append_little_endian(bytes, static_cast<std::int32_t>(triangle[k]));
  }
  write_file_atomic(path, bytes);
}

TriangleMesh read_ply_mesh(const fs::path& path) {
  const std::string file = path.string();
  const std::string data = ply::read_whole_file(file);

  // --- Header (ply_header.h).
  const ply::Header header = ply::parse_header(data, file);
  const std::vector<PlyElement>& elements = header.elements;

  // --- What we need: x, y, z of "vertex" and the index list of "face".
  const PlyElement* vertex_element = nullptr;
  const PlyElement* face_element = nullptr;
  for (const PlyElement& element : elements) {
    if (element.name == "vertex") vertex_element = &element;
    if (element.name == "face") face_element = &element;
  }
  if (!vertex_element) throw make_error(file, "element vertex", "missing (no vertices)");
  int coordinate_property[3] = {-1, -1, -1};
  const char* kAxes[3] = {"x", "y", "z"};
  for (std::size_t p = 0; p < vertex_element->properties.size(); ++p)
    for (int axis = 0; axis < 3; ++axis)
      if (vertex_element->properties[p].name == kAxes[axis] && !vertex_element->properties[p].is_list)
        coordinate_property[axis] = static_cast<int>(p);
  for (int axis = 0; axis < 3; ++axis)
    if (coordinate_property[axis] < 0)
      throw make_error(file, "element vertex", std::string("missing property '") + kAxes[axis] + "'");
  // Optional per-vertex colour: red, green, blue (integers scaled by their type's maximum,
  // floats taken as they are, both clamped to [0, 1]).
  int colour_property[3] = {-1, -1, -1};
  const char* kChannels[3] = {"red", "green", "blue"};
  for (std::size_t p = 0; p < vertex_element->properties.size(); ++p)
    for (int c = 0; c < 3; ++c)
      if (vertex_element->properties[p].name == kChannels[c] && !vertex_element->properties[p].is_list)
        colour_property[c] = static_cast<int>(p);
  const bool coloured = colour_property[0] >= 0 && colour_property[1] >= 0 && colour_property[2] >= 0;
  if (!face_element) throw make_error(file, "element face", "missing: a mesh needs triangles");
  int index_property = -1;
  for (std::size_t p = 0; p < face_element->properties.size(); ++p) {
    const PlyProperty& property = face_element->properties[p];
    if (property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index"))
      index_property = static_cast<int>(p);
  }
  if (index_property < 0) throw make_error(file, "element face", "missing list property 'vertex_indices'");
  if (!is_integer_type(face_element->properties[static_cast<std::size_t>(index_property)].type))
    throw make_error(file, "element face", "vertex_indices must be an integer list");
  if (face_element->count == 0) throw make_error(file, "element face", "no faces: a mesh needs triangles");

  // --- Data (ply::BodyReader: ASCII or binary of either byte order).
  ply::BodyReader reader(data, header, file);

  TriangleMesh mesh;
  std::vector<std::int64_t> corner_indices;  // 3 per triangle, validated once all vertices are known
  std::vector<std::uint64_t> triangle_face;  // the face each triangle came from, for error messages
  for (const PlyElement& element : elements) {
    const bool is_vertex = &element == vertex_element, is_face = &element == face_element;
    if (!is_vertex && !is_face) {
      reader.skip_element(element);
      continue;
    }
    // Each item takes at least one byte (or token): a larger count than the data left is corrupt.
    if (element.count > reader.remaining() && !element.properties.empty())
      throw make_error(file, "element " + element.name,
                       "declares " + std::to_string(element.count) + " items but the data ends earlier (truncated)");
    if (is_vertex) mesh.vertices.reserve(static_cast<std::size_t>(element.count));
    std::vector<std::int64_t> polygon;
    for (std::uint64_t item = 0; item < element.count; ++item) {
      reader.at(element.name, item);
      Eigen::Vector3d position = Eigen::Vector3d::Zero();
      Eigen::Vector3f colour = Eigen::Vector3f::Zero();
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (!property.is_list) {
          const int channel = !is_vertex || !coloured                     ? -1
                              : static_cast<int>(p) == colour_property[0] ? 0
                              : static_cast<int>(p) == colour_property[1] ? 1
                              : static_cast<int>(p) == colour_property[2] ? 2
                                                                          : -1;
          if (channel >= 0) {
            const double value = reader.read(property.type, property.name);
            if (!std::isfinite(value))
              throw make_error(file, reader.where(), "property " + property.name + " is not finite (NaN or inf)");
            colour[channel] = static_cast<float>(std::clamp(value / colour_scale(property.type), 0.0, 1.0));
            continue;
          }
          if (is_vertex &&
              (static_cast<int>(p) == coordinate_property[0] || static_cast<int>(p) == coordinate_property[1] ||
               static_cast<int>(p) == coordinate_property[2])) {
            const double value = reader.read(property.type, property.name);
            if (!std::isfinite(value))
              throw make_error(file, reader.where(), "property " + property.name + " is not finite (NaN or inf)");
            for (int axis = 0; axis < 3; ++axis)
              if (static_cast<int>(p) == coordinate_property[axis]) position[axis] = value;
          } else {
            reader.skip(property.type, property.name);
          }
          continue;
        }
        const bool wanted = is_face && static_cast<int>(p) == index_property;
        const std::size_t count = reader.list_length(property.count_type, property.name, 1000000);
        if (!wanted) {
          for (std::size_t k = 0; k < count; ++k) reader.skip(property.type, property.name);
          continue;
        }
        if (count < 3)
          throw make_error(file, reader.where(), "a face needs at least 3 vertices, has " + std::to_string(count));
        polygon.clear();
        for (std::size_t k = 0; k < count; ++k)
          polygon.push_back(static_cast<std::int64_t>(reader.read(property.type, property.name)));
        // Fan triangulation (exact for convex polygons, which is what PLY writers produce).
        for (std::size_t k = 1; k + 1 < count; ++k) {
          corner_indices.insert(corner_indices.end(), {polygon[0], polygon[k], polygon[k + 1]});
          triangle_face.push_back(item);
        }
      }
      if (is_vertex) mesh.vertices.push_back(position.cast<float>());
      if (is_vertex && coloured) mesh.vertex_colours.push_back(colour);
      if (is_vertex && !mesh.vertices.back().allFinite())
        throw make_error(file, reader.where(), "coordinate out of float range");
    }
  }

  const std::int64_t num_vertices = static_cast<std::int64_t>(mesh.vertices.size());
  mesh.triangles.reserve(corner_indices.size() / 3);
  for (std::size_t c = 0; c < corner_indices.size(); c += 3) {
    Eigen::Vector3i triangle;
    for (int k = 0; k < 3; ++k) {
      const std::int64_t index = corner_indices[c + k];
      if (index < 0 || index >= num_vertices)
        throw make_error(
            file, "face " + std::to_string(triangle_face[c / 3]),
            "vertex index " + std::to_string(index) + " out of range (" + std::to_string(num_vertices) + " vertices)");
      triangle[k] = static_cast<int>(index);
    }
    mesh.triangles.push_back(triangle);
  }
  if (mesh.triangles.empty()) throw make_error(file, "element face", "no triangles");
  return mesh;
}

}  // namespace panoscan
