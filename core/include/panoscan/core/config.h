// Configuration files (YAML, or JSON which is read as YAML) with command-line overrides.
//
// Keys are dotted paths into nested maps ("noise.preset"). Every getter marks its key as known,
// checks the type and range, and throws Error naming the file and the key. After all getters
// have run, check_all_used() rejects keys nobody asked for (typos do not pass silently).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace panoscan {

class Config {
 public:
  Config();  // empty config; origin "<defaults>"
  ~Config();
  Config(Config&&) noexcept;
  Config& operator=(Config&&) noexcept;

  static Config load_file(const std::filesystem::path& path);
  static Config from_string(const std::string& text, const std::string& origin);

  // Applies "key=value" (value parsed as YAML scalar). Throws if malformed.
  void apply_override(const std::string& key_equals_value);
  void set(const std::string& key, const std::string& value_yaml);

  bool has(const std::string& key) const;
  const std::string& origin() const;

  double get_double(const std::string& key, double default_value, double min_value, double max_value);
  int get_int(const std::string& key, int default_value, int min_value, int max_value);
  std::uint64_t get_u64(const std::string& key, std::uint64_t default_value);
  bool get_bool(const std::string& key, bool default_value);
  std::string get_string(const std::string& key, const std::string& default_value,
                         const std::vector<std::string>& allowed = {});
  std::vector<double> get_doubles(const std::string& key, const std::vector<double>& default_value,
                                  std::size_t expected_size);

  // Throws Error naming the file and the first key present in the file but never queried.
  void check_all_used() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace panoscan
