// Internal to panoscan_core: the one PLY header parser (Turk's polygon file format), used by the
// mesh reader (mesh_io.cpp) and the point-cloud reader (point_cloud_io.cpp). A header is "ply",
// a format line, then elements with typed scalar or list properties, comments and obj_info lines,
// up to "end_header"; each reader then decodes the body it needs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace panoscan::ply {

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class Type { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // the item type for lists
  bool is_list = false;
  Type count_type = Type::kUInt8;  // lists only (an integer type)
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  std::size_t body_offset = 0;  // first byte after the "end_header" line
};

// Type names of the PLY standard and their sized aliases (char/int8 ... double/float64); false for
// anything else.
bool parse_type(const std::string& word, Type* type);
std::size_t type_size(Type type);
bool is_integer_type(Type type);

// Parses the header at the start of `bytes`. Throws Error naming `file` and the header line for:
// no leading "ply" line, no "end_header" (truncated or not a PLY file), a missing or unknown
// format, a malformed or negative element count, a property before any element, unknown or
// unsupported types (a list count must be an integer type), a property without a name, and an
// unknown keyword.
Header parse_header(const std::string& bytes, const std::string& file);

// The whole file as bytes; Error naming the file when it is missing or unreadable.
std::string read_whole_file(const std::string& path);

}  // namespace panoscan::ply
