// Configuration files: YAML (or JSON, read as YAML) plus "key=value" overrides.
//
// The tree is kept as a yaml-cpp node. Keys are dotted paths into nested maps. Every getter
// records the key (and all its prefixes) as known, so that check_all_used() can walk the tree
// afterwards and reject keys that no getter asked for: a typo like "noise.presett" fails loudly
// instead of silently leaving the default in place.
//
// Errors name where a value came from: the file for keys read from a file, "command line" for
// keys set by apply_override()/set().
//
// yaml-cpp pitfalls this file avoids on purpose:
//  - Node assignment (a = b) on a defined node rebinds the *referenced* node, so walking a tree
//    with "cur = cur[key]" corrupts it. We walk with Node::reset().
//  - Non-const operator[] inserts missing keys; lookups go through const nodes.
//  - as<double>() on a quoted "3" succeeds; we parse scalars ourselves and reject quoted
//    strings where a number or boolean is expected.

#include "panoscan/core/config.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "panoscan/core/error.h"

namespace panoscan {
namespace {

constexpr const char* kCommandLineOrigin = "command line";

std::vector<std::string> split_dotted_key(const std::string& key) {
  std::vector<std::string> parts;
  std::string current;
  for (char c : key) {
    if (c == '.') {
      parts.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  parts.push_back(current);
  return parts;
}

bool is_valid_dotted_key(const std::string& key) {
  if (key.empty()) return false;
  for (const std::string& part : split_dotted_key(key)) {
    if (part.empty()) return false;
  }
  return true;
}

std::string trim(const std::string& text) {
  const char* whitespace = " \t\r\n";
  const std::size_t begin = text.find_first_not_of(whitespace);
  if (begin == std::string::npos) return "";
  const std::size_t end = text.find_last_not_of(whitespace);
  return text.substr(begin, end - begin + 1);
}

// Quoted scalars ('3' or "3") carry the non-specific tag "!"; plain scalars carry "?".
bool is_quoted_scalar(const YAML::Node& node) { return node.IsScalar() && node.Tag() == "!"; }

// A short, human-readable rendering of a node for error messages.
std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "no value";
  if (node.IsScalar()) {
    std::string text = node.Scalar();
    if (text.size() > 60) text = text.substr(0, 57) + "...";
    return "'" + text + "'";
  }
  if (node.IsSequence()) return "a list of " + std::to_string(node.size()) + " items";
  if (node.IsMap()) return "a map";
  return "an unknown value";
}

std::string format_number(double value) {
  std::ostringstream out;
  out.precision(std::numeric_limits<double>::max_digits10);
  out << value;
  // Shorter text when the shortest round-trippable form is simpler (e.g. "0.1" not "0.10000000000000001").
  for (int precision = 1; precision < std::numeric_limits<double>::max_digits10; ++precision) {
    std::ostringstream shorter;
    shorter.precision(precision);
    shorter << value;
    if (std::strtod(shorter.str().c_str(), nullptr) == value) return shorter.str();
  }
  return out.str();
}

// Full-string parses; return false when the text is not exactly one number of the kind asked for.
bool parse_double(const std::string& text, double* value) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const double parsed = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE) return false;
  *value = parsed;
  return true;
}

bool parse_int64(const std::string& text, long long* value) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long long parsed = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return false;
  *value = parsed;
  return true;
}

bool parse_uint64(const std::string& text, std::uint64_t* value) {
  // strtoull silently negates "-1" into a huge number; refuse any sign but '+'.
  if (text.empty() || text[0] == '-') return false;
  errno = 0;
  char* end = nullptr;
  const unsigned long long parsed = std::strtoull(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return false;
  *value = static_cast<std::uint64_t>(parsed);
  return true;
}

bool parse_bool(const std::string& text, bool* value) {
  static const char* const kTrue[] = {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"};
  static const char* const kFalse[] = {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"};
  for (const char* word : kTrue) {
    if (text == word) {
      *value = true;
      return true;
    }
  }
  for (const char* word : kFalse) {
    if (text == word) {
      *value = false;
      return true;
    }
  }
  return false;
}

// yaml-cpp keeps duplicate keys of a map silently (the first wins on lookup). A duplicated key in
// a config file is almost certainly a mistake, so it is reported.
void reject_duplicate_keys(const YAML::Node& node, const std::string& prefix, const std::string& origin) {
  if (node.IsMap()) {
    std::set<std::string> seen;
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      const std::string path = prefix.empty() ? key : prefix + "." + key;
      if (!seen.insert(key).second) {
        throw make_error(origin, path, "key appears twice (line " + std::to_string(entry.first.Mark().line + 1) + ")");
      }
      reject_duplicate_keys(entry.second, path, origin);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      reject_duplicate_keys(node[i], prefix + "[" + std::to_string(i) + "]", origin);
    }
  }
}

YAML::Node parse_yaml_document(const std::string& text, const std::string& origin) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    std::string where;
    if (!e.mark.is_null()) {
      where = " at line " + std::to_string(e.mark.line + 1) + ", column " + std::to_string(e.mark.column + 1);
    }
    throw make_error(origin, "", "syntax error" + where + ": " + e.msg);
  }
}

}  // namespace

struct Config::Impl {
  YAML::Node root{YAML::NodeType::Map};
  std::string file_origin = "<defaults>";
  bool has_overrides = false;
  std::string combined_origin = "<defaults>";
  // Every key a getter asked for, plus all its prefixes ("a.b.c" adds "a", "a.b", "a.b.c").
  std::set<std::string> known_keys;
  // Keys set from the command line (a key below one of them also came from there).
  std::set<std::string> overridden_keys;

  std::string origin_of(const std::string& key) const {
    const std::vector<std::string> parts = split_dotted_key(key);
    std::string prefix;
    for (const std::string& part : parts) {
      prefix = prefix.empty() ? part : prefix + "." + part;
      if (overridden_keys.count(prefix)) return kCommandLineOrigin;
    }
    return file_origin;
  }

  void mark_known(const std::string& key) {
    std::string prefix;
    for (const std::string& part : split_dotted_key(key)) {
      prefix = prefix.empty() ? part : prefix + "." + part;
      known_keys.insert(prefix);
    }
  }

  // Returns the node at `key`, or an undefined node if absent. Throws if an intermediate key
  // holds something other than a map (e.g. "noise: 3" when "noise.preset" is asked for).
  YAML::Node find(const std::string& key) const {
    YAML::Node current;
    current.reset(root);
    std::string walked;
    for (const std::string& part : split_dotted_key(key)) {
      if (!current.IsMap()) {
        throw make_error(origin_of(walked), walked,
                         "expected a map (holding '" + key + "'), found " + describe(current));
      }
      const YAML::Node& const_current = current;
      const YAML::Node child = const_current[part];
      if (!child.IsDefined()) return YAML::Node(YAML::NodeType::Undefined);
      current.reset(child);
      walked = walked.empty() ? part : walked + "." + part;
    }
    return current;
  }

  // Looks up a scalar for a getter: marks the key known; returns an undefined node when absent.
  YAML::Node find_for_getter(const std::string& key) {
    if (!is_valid_dotted_key(key)) throw make_error("", key, "invalid configuration key (internal error)");
    mark_known(key);
    return find(key);
  }

  [[noreturn]] void throw_type_error(const std::string& key, const std::string& expected,
                                     const YAML::Node& found) const {
    std::string found_text = describe(found);
    if (is_quoted_scalar(found)) found_text = "the quoted string " + found_text;
    throw make_error(origin_of(key), key, "expected " + expected + ", found " + found_text);
  }

  void set_value(const std::string& key, const YAML::Node& value, const std::string& what_for_errors) {
    if (!is_valid_dotted_key(key)) {
      throw make_error(kCommandLineOrigin, "",
                       "invalid key in " + what_for_errors + ": keys are dotted names like noise.preset");
    }
    const std::vector<std::string> parts = split_dotted_key(key);
    YAML::Node current;
    current.reset(root);
    std::string walked;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      const std::string& part = parts[i];
      walked = walked.empty() ? part : walked + "." + part;
      const YAML::Node& const_current = current;
      const YAML::Node existing = const_current[part];
      if (!existing.IsDefined() || existing.IsNull()) {
        current[part] = YAML::Node(YAML::NodeType::Map);
      } else if (!existing.IsMap()) {
        throw make_error(
            origin_of(walked), walked,
            "cannot apply " + what_for_errors + ": '" + walked + "' holds " + describe(existing) + ", not a map");
      }
      YAML::Node child = current[part];
      current.reset(child);
    }
    current[parts.back()] = value;
    overridden_keys.insert(key);
    if (!has_overrides) {
      has_overrides = true;
      combined_origin = file_origin + " + command line";
    }
  }

  // Walks the tree depth-first in file order and reports the first key nobody asked for.
  void check_subtree(const YAML::Node& node, const std::string& prefix) const {
    if (!node.IsMap()) return;
    for (const auto& entry : node) {
      const std::string path = prefix.empty() ? entry.first.Scalar() : prefix + "." + entry.first.Scalar();
      if (!known_keys.count(path)) {
        throw make_error(origin_of(path), path, "unknown key (a typo? it is not a setting of this program)");
      }
      check_subtree(entry.second, path);
    }
  }
};

Config::Config() : impl_(std::make_unique<Impl>()) {}
Config::~Config() = default;
Config::Config(Config&&) noexcept = default;
Config& Config::operator=(Config&&) noexcept = default;

Config Config::load_file(const std::filesystem::path& path) {
  const std::string origin = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw make_error(origin, "", "config file not found");
  if (std::filesystem::is_directory(path, ec)) throw make_error(origin, "", "is a directory, not a config file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw make_error(origin, "", "cannot open config file for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw make_error(origin, "", "error while reading config file");
  return from_string(text.str(), origin);
}

Config Config::from_string(const std::string& text, const std::string& origin) {
  YAML::Node document = parse_yaml_document(text, origin);
  Config config;
  config.impl_->file_origin = origin;
  config.impl_->combined_origin = origin;
  if (!document.IsDefined() || document.IsNull()) {
    return config;  // an empty file is an empty config: every setting takes its default
  }
  if (!document.IsMap()) {
    throw make_error(origin, "", "the top level must be a map of settings (key: value), found " + describe(document));
  }
  reject_duplicate_keys(document, "", origin);
  config.impl_->root.reset(document);
  return config;
}

void Config::apply_override(const std::string& key_equals_value) {
  const std::size_t equals = key_equals_value.find('=');
  if (equals == std::string::npos) {
    throw make_error(kCommandLineOrigin, "", "malformed override '" + key_equals_value + "': expected key=value");
  }
  const std::string key = trim(key_equals_value.substr(0, equals));
  if (!is_valid_dotted_key(key)) {
    throw make_error(kCommandLineOrigin, "",
                     "malformed override '" + key_equals_value + "': the key must be a dotted name like noise.preset");
  }
  set(key, key_equals_value.substr(equals + 1));
}

void Config::set(const std::string& key, const std::string& value_yaml) {
  const std::string what = "override '" + key + "=" + value_yaml + "'";
  const std::string trimmed = trim(value_yaml);
  YAML::Node value;
  if (trimmed.empty()) {
    value = YAML::Node(std::string());  // "key=" means the empty string, not "no value"
  } else {
    value = parse_yaml_document(trimmed, std::string(kCommandLineOrigin) + " (" + what + ")");
  }
  impl_->set_value(key, value, what);
}

bool Config::has(const std::string& key) const {
  if (!is_valid_dotted_key(key)) return false;
  try {
    return impl_->find(key).IsDefined();
  } catch (const Error&) {
    return false;  // a parent holds a scalar, so the key cannot exist
  }
}

const std::string& Config::origin() const { return impl_->combined_origin; }

double Config::get_double(const std::string& key, double default_value, double min_value, double max_value) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  double value = 0.0;
  if (!node.IsScalar() || is_quoted_scalar(node) || !parse_double(node.Scalar(), &value)) {
    impl_->throw_type_error(key, "a number", node);
  }
  if (!std::isfinite(value)) impl_->throw_type_error(key, "a finite number", node);
  if (!(value >= min_value && value <= max_value)) {
    throw make_error(impl_->origin_of(key), key,
                     "value " + node.Scalar() + " is out of range [" + format_number(min_value) + ", " +
                         format_number(max_value) + "]");
  }
  return value;
}

int Config::get_int(const std::string& key, int default_value, int min_value, int max_value) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  long long value = 0;
  if (!node.IsScalar() || is_quoted_scalar(node) || !parse_int64(node.Scalar(), &value)) {
    impl_->throw_type_error(key, "an integer", node);
  }
  if (value < min_value || value > max_value) {
    throw make_error(impl_->origin_of(key), key,
                     "value " + node.Scalar() + " is out of range [" + std::to_string(min_value) + ", " +
                         std::to_string(max_value) + "]");
  }
  return static_cast<int>(value);
}

std::uint64_t Config::get_u64(const std::string& key, std::uint64_t default_value) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  std::uint64_t value = 0;
  if (!node.IsScalar() || is_quoted_scalar(node) || !parse_uint64(node.Scalar(), &value)) {
    impl_->throw_type_error(key, "a non-negative integer (at most 18446744073709551615)", node);
  }
  return value;
}

bool Config::get_bool(const std::string& key, bool default_value) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  bool value = false;
  if (!node.IsScalar() || is_quoted_scalar(node) || !parse_bool(node.Scalar(), &value)) {
    impl_->throw_type_error(key, "true or false", node);
  }
  return value;
}

std::string Config::get_string(const std::string& key, const std::string& default_value,
                               const std::vector<std::string>& allowed) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  if (!node.IsScalar()) impl_->throw_type_error(key, "a text value", node);
  const std::string value = node.Scalar();
  if (!allowed.empty()) {
    bool is_allowed = false;
    std::string allowed_list;
    for (const std::string& candidate : allowed) {
      if (candidate == value) is_allowed = true;
      allowed_list += (allowed_list.empty() ? "" : ", ") + candidate;
    }
    if (!is_allowed) {
      throw make_error(impl_->origin_of(key), key, "'" + value + "' is not one of: " + allowed_list);
    }
  }
  return value;
}

// expected_size 0 accepts a list of any length.
std::vector<double> Config::get_doubles(const std::string& key, const std::vector<double>& default_value,
                                        std::size_t expected_size) {
  const YAML::Node node = impl_->find_for_getter(key);
  if (!node.IsDefined()) return default_value;
  const std::string expected =
      expected_size == 0 ? std::string("a list of numbers") : "a list of " + std::to_string(expected_size) + " numbers";
  if (!node.IsSequence()) impl_->throw_type_error(key, expected, node);
  if (expected_size != 0 && node.size() != expected_size) {
    throw make_error(impl_->origin_of(key), key,
                     "expected " + std::to_string(expected_size) + " numbers, found " + std::to_string(node.size()));
  }
  std::vector<double> values;
  values.reserve(node.size());
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node item = node[i];
    double value = 0.0;
    if (!item.IsScalar() || is_quoted_scalar(item) || !parse_double(item.Scalar(), &value) || !std::isfinite(value)) {
      throw make_error(impl_->origin_of(key), key,
                       "item " + std::to_string(i) + ": expected a finite number, found " + describe(item));
    }
    values.push_back(value);
  }
  return values;
}

void Config::check_all_used() const { impl_->check_subtree(impl_->root, ""); }

}  // namespace panoscan
