// Internal to panoscan_core: the one PLY header parser and the one body decoder (Turk's polygon
// file format), used by the mesh reader (mesh_io.cpp) and the point-cloud reader
// (point_cloud_io.cpp). A header is "ply", a format line, then elements with typed scalar or list
// properties, comments and obj_info lines, up to "end_header"; each reader then decodes the
// values it needs with BodyReader (ASCII tokens or binary of either byte order) and skips the rest.
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

// Reads the body one value at a time, as double (exact for every PLY type). ASCII tokens are parsed
// locale-independently (std::from_chars) and must be integers for integer types; binary values are
// decoded in the file's byte order by explicit shifts, independent of the host's. Every error names
// the file, the instance set by at() and the property (e.g. "vertex 17 property z"); the context is
// formatted only on error, so reading costs no string work per value.
class BodyReader {
 public:
  // `bytes` must outlive the reader.
  BodyReader(const std::string& bytes, const Header& header, std::string file);

  // The element instance being read (for error messages); `element` must outlive the reads.
  void at(const std::string& element, std::uint64_t index) {
    element_ = &element;
    index_ = index;
  }
  double read(Type type, const std::string& property);
  void skip(Type type, const std::string& property);
  // A list's length (read with its count type); an Error above `max_length`.
  std::size_t list_length(Type count_type, const std::string& property, std::size_t max_length = 100000000);
  // Every instance of `element` (scalars and lists).
  void skip_element(const Element& element);
  // Bytes left (binary), or an upper bound on the values left (ASCII: every token but the last takes
  // at least 2 bytes), to bound allocations on absurd counts.
  std::uint64_t remaining() const;
  // "vertex 17" (the instance) and "vertex 17 property z".
  std::string where() const;
  std::string where(const std::string& property) const { return where() + " property " + property; }

 private:
  [[noreturn]] void truncated(const std::string& property) const;

  const std::string& bytes_;
  std::size_t pos_;
  Format format_;
  std::string file_;
  const std::string* element_ = nullptr;
  std::uint64_t index_ = 0;
};

// The whole file as bytes; Error naming the file when it is missing or unreadable.
std::string read_whole_file(const std::string& path);

}  // namespace panoscan::ply
