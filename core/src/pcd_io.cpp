// PCD files (PCL's point cloud data format, v0.5-0.7): a text header of keyword lines
//   [# comments] VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS, DATA
// then the points: `DATA ascii` (one point per line, COUNT values per field), `DATA binary`
// (little-endian records, the fields of a point together) or `DATA binary_compressed` (two uint32
// sizes, then the LZF-compressed fields one after another, all points of a field together).
//
// The reader is strict on what it needs and says where a file is wrong: every count must agree
// (SIZE/TYPE/COUNT with FIELDS, POINTS with WIDTH*HEIGHT, each ASCII line with the sum of COUNT),
// SIZE must suit TYPE (I/U: 1, 2, 4, 8; F: 4, 8), x, y and z must be single-count fields, the data
// must be long enough. Fields it does not need are skipped by their declared size; ASCII values
// are parsed locale-independently (std::from_chars).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "cloud_columns.h"
#include "panoscan/core/error.h"
#include "ply_header.h"  // ply::read_whole_file

namespace panoscan::detail {

namespace {

struct Field {
  std::string name;
  std::size_t size = 4;
  char type = 'F';
  std::size_t count = 1;
  std::size_t offset = 0;  // binary: byte offset within a point's record
  std::size_t first_value = 0;  // ascii: index of its first value within a line
};

enum class DataKind { kAscii, kBinary, kBinaryCompressed };

std::vector<std::string> split_words(const std::string& line) {
  std::vector<std::string> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    std::size_t end = i;
    while (end < line.size() && !std::isspace(static_cast<unsigned char>(line[end]))) ++end;
    if (end > i) words.push_back(line.substr(i, end - i));
    i = end;
  }
  return words;
}

bool parse_unsigned(const std::string& word, std::uint64_t* value) {
  const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), *value);
  return error == std::errc() && end == word.data() + word.size();
}

bool parse_double(const char* first, const char* last, double* value) {
  if (last - first > 1 && *first == '+') ++first;
  const auto [end, error] = std::from_chars(first, last, *value);
  return error == std::errc() && end == last;
}

// One value of a binary record (little-endian, by shifts: independent of the host's byte order).
double decode(const unsigned char* p, char type, std::size_t size) {
  std::uint64_t bits = 0;
  for (std::size_t k = 0; k < size; ++k) bits |= static_cast<std::uint64_t>(p[k]) << (8 * k);
  if (type == 'F') {
    if (size == 4) {
      const std::uint32_t narrow = static_cast<std::uint32_t>(bits);
      float f;
      std::memcpy(&f, &narrow, 4);
      return f;
    }
    double d;
    std::memcpy(&d, &bits, 8);
    return d;
  }
  if (type == 'U') return static_cast<double>(bits);
  // Signed: sign-extend from `size` bytes.
  if (size < 8 && (bits >> (8 * size - 1)) & 1) bits |= ~std::uint64_t(0) << (8 * size);
  return static_cast<double>(static_cast<std::int64_t>(bits));
}

// LZF (liblzf's format, as PCL writes binary_compressed), every step bounds-checked.
std::string lzf_decompress(const std::string& file, const unsigned char* in, std::size_t in_size,
                           std::size_t out_size) {
  std::string out(out_size, '\0');
  std::size_t ip = 0, op = 0;
  auto corrupt = [&](const std::string& why) {
    return make_error(file, "DATA binary_compressed", "corrupt compressed data (" + why + " at byte " +
                                                          std::to_string(ip) + " of " + std::to_string(in_size) + ")");
  };
  while (ip < in_size) {
    std::size_t control = in[ip++];
    if (control < 32) {
      const std::size_t length = control + 1;
      if (ip + length > in_size) throw corrupt("a literal run past the end of the input");
      if (op + length > out_size) throw corrupt("more data than the declared uncompressed size");
      std::memcpy(&out[op], in + ip, length);
      ip += length;
      op += length;
    } else {
      std::size_t length = control >> 5;
      std::size_t back = (control & 0x1f) << 8;
      if (length == 7) {
        if (ip >= in_size) throw corrupt("a back reference cut short");
        length += in[ip++];
      }
      if (ip >= in_size) throw corrupt("a back reference cut short");
      back += in[ip++];
      length += 2;
      if (back + 1 > op) throw corrupt("a back reference before the start");
      if (op + length > out_size) throw corrupt("more data than the declared uncompressed size");
      std::size_t ref = op - back - 1;
      for (std::size_t k = 0; k < length; ++k) out[op++] = out[ref++];
    }
  }
  if (op != out_size)
    throw make_error(file, "DATA binary_compressed",
                     "corrupt compressed data (" + std::to_string(op) + " bytes decompressed, the header says " +
                         std::to_string(out_size) + ")");
  return out;
}

}  // namespace

PcdData read_pcd(const std::filesystem::path& path, const std::vector<std::string>& extra) {
  const std::string file = path.string();
  const std::string bytes = ply::read_whole_file(file);
  PcdData out;

  // --- Header.
  std::vector<Field> fields;
  bool have_fields = false, have_size = false, have_type = false, have_count = false, have_width = false,
       have_height = false, have_points = false, have_data = false;
  std::uint64_t width = 0, height = 1, points = 0;
  DataKind kind = DataKind::kAscii;
  std::size_t offset = 0;
  std::uint64_t line_number = 0;
  std::vector<std::string> sizes, types, counts;
  bool seen_keyword = false;
  while (offset < bytes.size() && !have_data) {
    std::size_t newline = bytes.find('\n', offset);
    const bool last_line = newline == std::string::npos;
    if (last_line) newline = bytes.size();
    std::string line = bytes.substr(offset, newline - offset);
    offset = last_line ? bytes.size() : newline + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = "header line " + std::to_string(line_number);
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    const std::vector<std::string> words = split_words(line);
    if (words.empty()) continue;
    const std::string& keyword = words[0];
    const std::vector<std::string> args(words.begin() + 1, words.end());
    const bool first_keyword = !seen_keyword;
    seen_keyword = true;
    auto one_unsigned = [&](const char* name) {
      std::uint64_t value = 0;
      if (args.size() != 1 || !parse_unsigned(args[0], &value))
        throw make_error(file, name, "expects one non-negative integer (" + where + ": '" + line + "')");
      return value;
    };
    if (keyword == "VERSION") {
      // Any version: the keywords decide.
    } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
      if (args.empty()) throw make_error(file, "FIELDS", "names no fields (" + where + ")");
      fields.clear();
      for (const std::string& name : args) {
        Field field;
        field.name = name;
        if (name != "_")
          for (const Field& other : fields)
            if (other.name == name) throw make_error(file, "FIELDS", "field '" + name + "' appears twice (" + where + ")");
        fields.push_back(field);
      }
      have_fields = true;
    } else if (keyword == "SIZE") {
      sizes = args;
      have_size = true;
    } else if (keyword == "TYPE") {
      types = args;
      have_type = true;
    } else if (keyword == "COUNT") {
      counts = args;
      have_count = true;
    } else if (keyword == "WIDTH") {
      width = one_unsigned("WIDTH");
      have_width = true;
    } else if (keyword == "HEIGHT") {
      height = one_unsigned("HEIGHT");
      have_height = true;
    } else if (keyword == "POINTS") {
      points = one_unsigned("POINTS");
      have_points = true;
    } else if (keyword == "VIEWPOINT") {
      if (args.size() != 7) throw make_error(file, "VIEWPOINT", "expects 7 numbers tx ty tz qw qx qy qz (" + where + ")");
      double values[7];
      for (int k = 0; k < 7; ++k)
        if (!parse_double(args[k].data(), args[k].data() + args[k].size(), &values[k]) || !std::isfinite(values[k]))
          throw make_error(file, "VIEWPOINT", "'" + args[k] + "' is not a finite number (" + where + ")");
      out.has_viewpoint = true;
      out.viewpoint_translation = Eigen::Vector3d(values[0], values[1], values[2]);
      out.viewpoint_quaternion_wxyz = Eigen::Vector4d(values[3], values[4], values[5], values[6]);
    } else if (keyword == "DATA") {
      if (args.size() != 1) throw make_error(file, "DATA", "expects ascii, binary or binary_compressed (" + where + ")");
      if (args[0] == "ascii")
        kind = DataKind::kAscii;
      else if (args[0] == "binary")
        kind = DataKind::kBinary;
      else if (args[0] == "binary_compressed")
        kind = DataKind::kBinaryCompressed;
      else
        throw make_error(file, "DATA", "unknown data kind '" + args[0] + "' (ascii, binary or binary_compressed)");
      have_data = true;
    } else {
      throw make_error(file, where,
                       first_keyword ? "not a PCD file (unknown keyword '" + keyword + "')"
                                        : "unknown PCD header keyword '" + keyword + "'");
    }
  }
  if (!have_data) throw make_error(file, "DATA", "no DATA line (truncated header, or not a PCD file)");
  if (!have_fields) throw make_error(file, "FIELDS", "missing from the header");
  if (!have_size) throw make_error(file, "SIZE", "missing from the header");
  if (!have_type) throw make_error(file, "TYPE", "missing from the header");
  const std::size_t n_fields = fields.size();
  auto check_length = [&](const std::vector<std::string>& list, const char* name) {
    if (list.size() != n_fields)
      throw make_error(file, name,
                       std::to_string(list.size()) + " entries for " + std::to_string(n_fields) + " FIELDS");
  };
  check_length(sizes, "SIZE");
  check_length(types, "TYPE");
  if (have_count) check_length(counts, "COUNT");
  std::size_t record = 0, values_per_point = 0;
  for (std::size_t f = 0; f < n_fields; ++f) {
    Field& field = fields[f];
    std::uint64_t size = 0, count = 1;
    if (!parse_unsigned(sizes[f], &size) || (size != 1 && size != 2 && size != 4 && size != 8))
      throw make_error(file, "SIZE", "field '" + field.name + "' has size '" + sizes[f] + "' (1, 2, 4 or 8)");
    if (types[f].size() != 1 || std::string("IUF").find(types[f][0]) == std::string::npos)
      throw make_error(file, "TYPE", "field '" + field.name + "' has type '" + types[f] + "' (I, U or F)");
    if (types[f][0] == 'F' && size != 4 && size != 8)
      throw make_error(file, "SIZE", "field '" + field.name + "' is F of size " + sizes[f] + " (4 or 8)");
    if (have_count && (!parse_unsigned(counts[f], &count) || count < 1 || count > 1000000))
      throw make_error(file, "COUNT", "field '" + field.name + "' has count '" + counts[f] + "' (1 to 1000000)");
    field.size = size;
    field.type = types[f][0];
    field.count = count;
    field.offset = record;
    field.first_value = values_per_point;
    record += size * count;
    values_per_point += count;
  }
  auto find_field = [&](const std::string& name) -> int {
    for (std::size_t f = 0; f < n_fields; ++f)
      if (fields[f].name == name) return static_cast<int>(f);
    return -1;
  };
  int xyz[3];
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    xyz[k] = find_field(axes[k]);
    if (xyz[k] < 0) throw make_error(file, std::string("field ") + axes[k], "missing from FIELDS (x, y and z are required)");
    if (fields[xyz[k]].count != 1) throw make_error(file, std::string("field ") + axes[k], "must have COUNT 1");
  }
  std::vector<int> extra_field(extra.size(), -1);
  for (std::size_t k = 0; k < extra.size(); ++k) {
    extra_field[k] = find_field(extra[k]);
    if (extra_field[k] >= 0 && fields[extra_field[k]].count != 1)
      throw make_error(file, "field " + extra[k], "must have COUNT 1");
  }
  if (!have_width && !have_points) throw make_error(file, "WIDTH", "missing from the header (and no POINTS)");
  if (have_width) {
    if (height > 0 && width > std::numeric_limits<std::uint64_t>::max() / height)
      throw make_error(file, "WIDTH", "WIDTH * HEIGHT overflows");
    if (have_points && points != width * height)
      throw make_error(file, "POINTS",
                       std::to_string(points) + " but WIDTH * HEIGHT = " + std::to_string(width) + " * " +
                           std::to_string(height) + " = " + std::to_string(width * height));
    if (!have_points) points = width * height;
  } else if (have_height && height != 1 && points % std::max<std::uint64_t>(height, 1) != 0) {
    throw make_error(file, "HEIGHT", "does not divide POINTS");
  }
  out.declared_points = points;
  out.format = kind == DataKind::kAscii    ? "pcd ascii"
               : kind == DataKind::kBinary ? "pcd binary"
                                           : "pcd binary_compressed";
  out.columns.assign(extra.size(), {});

  // --- Data.
  const std::size_t data_start = offset;
  const std::size_t left = bytes.size() - data_start;
  std::vector<double> extra_values(extra.size());
  // `line` is the ASCII line of the point (0 for binary data), for the message.
  auto keep = [&](std::uint64_t index, const Eigen::Vector3d& p, std::uint64_t line) {
    if (!p.allFinite()) {
      if (p.array().isNaN().any()) {
        ++out.dropped_invalid;  // PCL's mark of an invalid point
        return;
      }
      throw make_error(file, line > 0 ? "line " + std::to_string(line) : "point " + std::to_string(index),
                       "coordinate is infinite");
    }
    out.points.push_back(p);
    out.kept.push_back(index);
    for (std::size_t k = 0; k < extra.size(); ++k)
      if (extra_field[k] >= 0) out.columns[k].push_back(extra_values[k]);
  };

  if (kind == DataKind::kAscii) {
    out.first_data_line = line_number + 1;
    // Every point takes at least 2 bytes per value (a digit and a separator) but the last.
    if (points > 0 && (values_per_point == 0 || points - 1 > left / (2 * values_per_point)))
      throw make_error(file, "POINTS",
                       "declares " + std::to_string(points) + " points but the data ends earlier (truncated)");
    out.points.reserve(points);
    std::vector<const char*> begins(values_per_point), ends(values_per_point);
    std::uint64_t point = 0;
    std::size_t pos = data_start;
    while (pos < bytes.size()) {
      std::size_t newline = bytes.find('\n', pos);
      if (newline == std::string::npos) newline = bytes.size();
      ++line_number;
      const char* first = bytes.data() + pos;
      const char* last = bytes.data() + newline;
      pos = newline + 1;
      std::size_t found = 0;
      const char* c = first;
      while (c < last) {
        while (c < last && std::isspace(static_cast<unsigned char>(*c))) ++c;
        if (c >= last) break;
        const char* token_end = c;
        while (token_end < last && !std::isspace(static_cast<unsigned char>(*token_end))) ++token_end;
        if (found < values_per_point) begins[found] = c, ends[found] = token_end;
        ++found;
        c = token_end;
      }
      if (found == 0) continue;  // blank lines are allowed
      const std::string where = "line " + std::to_string(line_number);
      if (point >= points)
        throw make_error(file, where, "more data lines than the " + std::to_string(points) + " POINTS of the header");
      if (found != values_per_point)
        throw make_error(file, where,
                         std::to_string(found) + " values, expected " + std::to_string(values_per_point) +
                             " (the COUNTs of FIELDS)");
      auto value_of = [&](const Field& field, std::size_t v) {
        const std::size_t index = field.first_value + v;
        double value = 0;
        if (!parse_double(begins[index], ends[index], &value))
          throw make_error(file, where + " field " + field.name,
                           "'" + std::string(begins[index], std::min<std::ptrdiff_t>(ends[index] - begins[index], 40)) +
                               "' is not a number");
        if (field.type != 'F' && std::isfinite(value) && value != std::floor(value))
          throw make_error(file, where + " field " + field.name,
                           "'" + std::string(begins[index], ends[index]) + "' is not an integer");
        // The declared type decides the value, as in binary data: "0.1" of an F 4 field is float(0.1).
        if (field.type == 'F' && field.size == 4) return double(static_cast<float>(value));
        return value;
      };
      // Every value must be a number, the ones not used too (a file is valid or it is not).
      for (const Field& field : fields)
        for (std::size_t v = 0; v < field.count; ++v) value_of(field, v);
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k) p[k] = value_of(fields[xyz[k]], 0);
      for (std::size_t k = 0; k < extra.size(); ++k)
        if (extra_field[k] >= 0) extra_values[k] = value_of(fields[extra_field[k]], 0);
      keep(point, p, line_number);
      ++point;
    }
    if (point < points)
      throw make_error(file, "POINTS",
                       "the header declares " + std::to_string(points) + " points, the data has " +
                           std::to_string(point) + " lines (truncated)");
    return out;
  }

  // Binary (records) and binary_compressed (fields one after another once decompressed).
  std::string decompressed;
  const unsigned char* base = reinterpret_cast<const unsigned char*>(bytes.data()) + data_start;
  bool by_field = false;
  if (record == 0 && points > 0) throw make_error(file, "FIELDS", "the fields take no bytes");
  if (kind == DataKind::kBinary) {
    if (points > 0 && points > left / record)
      throw make_error(file, "DATA binary",
                       "truncated: " + std::to_string(left) + " bytes of data for " + std::to_string(points) +
                           " points of " + std::to_string(record) + " bytes");
  } else {
    if (left < 8) throw make_error(file, "DATA binary_compressed", "truncated: no compressed-size header");
    std::uint64_t compressed = 0, uncompressed = 0;
    for (int k = 0; k < 4; ++k) compressed |= std::uint64_t(base[k]) << (8 * k);
    for (int k = 0; k < 4; ++k) uncompressed |= std::uint64_t(base[4 + k]) << (8 * k);
    if (compressed > left - 8)
      throw make_error(file, "DATA binary_compressed",
                       "truncated: " + std::to_string(left - 8) + " bytes of compressed data, the header says " +
                           std::to_string(compressed));
    if (points > 0 && points > std::numeric_limits<std::uint64_t>::max() / record)
      throw make_error(file, "POINTS", "too many points");
    if (uncompressed != points * record)
      throw make_error(file, "DATA binary_compressed",
                       "uncompressed size " + std::to_string(uncompressed) + " does not match " +
                           std::to_string(points) + " points of " + std::to_string(record) + " bytes");
    // LZF expands at most ~90 times (a 3-byte back reference gives 264 bytes): a larger claim is corrupt.
    if (uncompressed > 100 * compressed + 64)
      throw make_error(file, "DATA binary_compressed",
                       "uncompressed size " + std::to_string(uncompressed) + " is impossible for " +
                           std::to_string(compressed) + " compressed bytes");
    decompressed = lzf_decompress(file, base + 8, compressed, uncompressed);
    base = reinterpret_cast<const unsigned char*>(decompressed.data());
    by_field = true;
  }
  std::vector<std::size_t> field_base(n_fields, 0);  // binary_compressed: start of each field's block
  for (std::size_t f = 1; f < n_fields; ++f)
    field_base[f] = field_base[f - 1] + points * fields[f - 1].size * fields[f - 1].count;
  auto at = [&](int f, std::uint64_t i) {
    const Field& field = fields[f];
    const unsigned char* p = by_field ? base + field_base[f] + i * field.size * field.count : base + i * record + field.offset;
    return decode(p, field.type, field.size);
  };
  out.points.reserve(points);
  for (std::uint64_t i = 0; i < points; ++i) {
    const Eigen::Vector3d p(at(xyz[0], i), at(xyz[1], i), at(xyz[2], i));
    for (std::size_t k = 0; k < extra.size(); ++k)
      if (extra_field[k] >= 0) extra_values[k] = at(extra_field[k], i);
    keep(i, p, 0);
  }
  return out;
}

}  // namespace panoscan::detail
