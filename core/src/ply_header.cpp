#include "ply_header.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
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

BodyReader::BodyReader(const std::string& bytes, const Header& header, std::string file)
    : bytes_(bytes), pos_(header.body_offset), format_(header.format), file_(std::move(file)) {}

std::string BodyReader::where() const {
  return element_ ? *element_ + " " + std::to_string(index_) : std::string("data");
}

void BodyReader::truncated(const std::string& property) const {
  throw make_error(file_, where(property), "truncated data (the file ends early)");
}

double BodyReader::read(Type type, const std::string& property) {
  if (format_ == Format::kAscii) {
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (pos_ >= bytes_.size()) truncated(property);
    std::size_t end = pos_;
    while (end < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[end]))) ++end;
    const char* first = bytes_.data() + pos_;
    const char* last = bytes_.data() + end;
    pos_ = end;
    const char* number = last - first > 1 && *first == '+' ? first + 1 : first;
    double value = 0.0;
    const auto [parse_end, error] = std::from_chars(number, last, value);
    // from_chars reports out-of-range values (1e999) as an error; so does this reader.
    if (error != std::errc() || parse_end != last)
      throw make_error(file_, where(property),
                       "'" + std::string(first, std::min<std::ptrdiff_t>(last - first, 40)) + "' is not a number");
    if (is_integer_type(type) && std::isfinite(value) && value != std::floor(value))
      throw make_error(file_, where(property),
                       "'" + std::string(first, std::min<std::ptrdiff_t>(last - first, 40)) + "' is not an integer");
    // The declared type decides the value, as in a binary file: "0.1" of a float property is float(0.1).
    if (type == Type::kFloat32) return static_cast<float>(value);
    return value;
  }
  const std::size_t size = type_size(type);
  if (size > bytes_.size() - pos_) truncated(property);
  std::uint64_t bits = 0;
  const bool little = format_ == Format::kBinaryLittleEndian;
  for (std::size_t k = 0; k < size; ++k) {
    const std::size_t shift = 8 * (little ? k : size - 1 - k);
    bits |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes_[pos_ + k])) << shift;
  }
  pos_ += size;
  switch (type) {
    case Type::kInt8: return static_cast<std::int8_t>(bits);
    case Type::kUInt8: return static_cast<std::uint8_t>(bits);
    case Type::kInt16: return static_cast<std::int16_t>(bits);
    case Type::kUInt16: return static_cast<std::uint16_t>(bits);
    case Type::kInt32: return static_cast<std::int32_t>(bits);
    case Type::kUInt32: return static_cast<std::uint32_t>(bits);
    case Type::kFloat32: {
      const std::uint32_t narrow = static_cast<std::uint32_t>(bits);
      float f;
      std::memcpy(&f, &narrow, sizeof f);
      return f;
    }
    case Type::kFloat64: {
      double d;
      std::memcpy(&d, &bits, sizeof d);
      return d;
    }
  }
  return 0.0;
}

void BodyReader::skip(Type type, const std::string& property) {
  if (format_ == Format::kAscii) {
    read(type, property);
    return;
  }
  const std::size_t size = type_size(type);
  if (size > bytes_.size() - pos_) truncated(property);
  pos_ += size;
}

std::size_t BodyReader::list_length(Type count_type, const std::string& property, std::size_t max_length) {
  const double count = read(count_type, property);
  if (!(count >= 0) || count != std::floor(count) || count > double(max_length))
    throw make_error(file_, where(property), "invalid list length " + std::to_string(count));
  return static_cast<std::size_t>(count);
}

void BodyReader::skip_element(const Element& element) {
  if (element.properties.empty()) return;
  // Each instance takes at least one byte (or token): a larger count than the data left is corrupt.
  if (element.count > remaining())
    throw make_error(file_, "element " + element.name,
                     "declares " + std::to_string(element.count) + " items but the data ends earlier (truncated)");
  for (std::uint64_t i = 0; i < element.count; ++i) {
    at(element.name, i);
    for (const Property& property : element.properties) {
      if (property.is_list) {
        const std::size_t n = list_length(property.count_type, property.name);
        for (std::size_t k = 0; k < n; ++k) skip(property.type, property.name);
      } else {
        skip(property.type, property.name);
      }
    }
  }
}

std::uint64_t BodyReader::remaining() const {
  const std::uint64_t left = bytes_.size() - pos_;
  return format_ == Format::kAscii ? left / 2 + 1 : left;
}

}  // namespace panoscan::ply
