#include "ply_header.h"

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "panoscan/core/error.h"

namespace panoscan::ply {

bool parse_type(const std::string& word, Type* type) {
  static const struct {
    const char* name;
    Type type;
  } kTypes[] = {
      {"char", Type::kInt8},     {"int8", Type::kInt8},       {"uchar", Type::kUInt8},    {"uint8", Type::kUInt8},
      {"short", Type::kInt16},   {"int16", Type::kInt16},     {"ushort", Type::kUInt16},  {"uint16", Type::kUInt16},
      {"int", Type::kInt32},     {"int32", Type::kInt32},     {"uint", Type::kUInt32},    {"uint32", Type::kUInt32},
      {"float", Type::kFloat32}, {"float32", Type::kFloat32}, {"double", Type::kFloat64}, {"float64", Type::kFloat64}};
  for (const auto& entry : kTypes)
    if (word == entry.name) {
      *type = entry.type;
      return true;
    }
  return false;
}

std::size_t type_size(Type type) {
  switch (type) {
    case Type::kInt8:
    case Type::kUInt8: return 1;
    case Type::kInt16:
    case Type::kUInt16: return 2;
    case Type::kInt32:
    case Type::kUInt32:
    case Type::kFloat32: return 4;
    case Type::kFloat64: return 8;
  }
  return 0;
}

bool is_integer_type(Type type) { return type != Type::kFloat32 && type != Type::kFloat64; }

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw make_error(path, "", "file not found (or not a regular file)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw make_error(path, "", "cannot open for reading");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw make_error(path, "", "read error");
  return buffer.str();
}

Header parse_header(const std::string& data, const std::string& file) {
  if (data.compare(0, 3, "ply") != 0 || (data.size() > 3 && data[3] != '\n' && data[3] != '\r'))
    throw make_error(file, "header", "not a PLY file (it does not start with 'ply')");
  Header header;
  std::size_t offset = 0;
  bool header_ended = false, have_format = false;
  int line_number = 0;
  while (offset < data.size()) {
    const std::size_t newline = data.find('\n', offset);
    if (newline == std::string::npos) break;
    std::string line = data.substr(offset, newline - offset);
    offset = newline + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    const std::string where = "header line " + std::to_string(line_number);
    if (line_number == 1 || keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") {
      header_ended = true;
      break;
    }
    if (keyword == "format") {
      std::string name, version;
      words >> name >> version;
      if (name == "ascii")
        header.format = Format::kAscii;
      else if (name == "binary_little_endian")
        header.format = Format::kBinaryLittleEndian;
      else if (name == "binary_big_endian")
        header.format = Format::kBinaryBigEndian;
      else
        throw make_error(file, "format", "unknown PLY format '" + name + "' (" + where + ")");
      have_format = true;
    } else if (keyword == "element") {
      Element element;
      std::string count, extra;
      words >> element.name >> count >> extra;
      char* end = nullptr;
      errno = 0;
      const unsigned long long value = std::strtoull(count.c_str(), &end, 10);
      if (element.name.empty() || count.empty() || !extra.empty())
        throw make_error(file, where, "malformed element declaration '" + line + "'");
      if (*end != '\0' || count[0] == '-' || errno == ERANGE)
        throw make_error(file, "element " + element.name, "count '" + count + "' is not a non-negative integer");
      element.count = value;
      header.elements.push_back(element);
    } else if (keyword == "property") {
      if (header.elements.empty()) throw make_error(file, where, "property before any element");
      Property property;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type >> property.name;
        property.is_list = true;
        if (!parse_type(count_type, &property.count_type) || !is_integer_type(property.count_type))
          throw make_error(file, where, "bad list count type '" + count_type + "'");
        if (!parse_type(item_type, &property.type)) throw make_error(file, where, "unknown type '" + item_type + "'");
      } else {
        words >> property.name;
        if (!parse_type(type, &property.type)) throw make_error(file, where, "unknown type '" + type + "'");
      }
      if (property.name.empty()) throw make_error(file, where, "property without a name");
      header.elements.back().properties.push_back(property);
    } else {
      throw make_error(file, where, "unknown header keyword '" + keyword + "'");
    }
  }
  if (!header_ended) throw make_error(file, "header", "no 'end_header' line (truncated or not a PLY file)");
  if (!have_format) throw make_error(file, "format", "missing 'format' line in the PLY header");
  header.body_offset = offset;
  return header;
}

}  // namespace panoscan::ply
