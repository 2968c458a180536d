#include "panoscan/core/json_file.h"

#include <fstream>
#include <sstream>
#include <system_error>

#include "panoscan/core/error.h"

namespace panoscan {

nlohmann::json parse_json_text(const std::string& text, const std::string& origin) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for numbers like 1e999
    throw make_error(origin, "", std::string("not valid JSON: ") + e.what());
  }
}

nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& hint) {
  const std::string file = path.string();
  const std::string suffix = hint.empty() ? "" : " (" + hint + ")";
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw make_error(file, "", "is a directory, expected a JSON file" + suffix);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw make_error(file, "", "cannot open" + suffix);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw make_error(file, "", "error while reading");
  return parse_json_text(text.str(), file);
}

}  // namespace panoscan
