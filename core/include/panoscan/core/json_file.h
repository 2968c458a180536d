// The one way PanoScan reads a JSON document from a file or a string: every failure becomes an
// Error naming the file (or origin), so that no reader shows nlohmann's exception unwrapped.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace panoscan {

// Parses `path`. Throws Error naming the file when it is missing, is a directory, cannot be read,
// or is not valid JSON (numbers out of range such as 1e999 included). `hint` is added to the
// "cannot open" message, e.g. "not a panorama folder?".
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& hint = "");

// Parses `text`; Error naming `origin` when it is not valid JSON.
nlohmann::json parse_json_text(const std::string& text, const std::string& origin);

}  // namespace panoscan
