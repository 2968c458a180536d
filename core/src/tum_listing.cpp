// TUM RGB-D listings and the association of colour and depth timestamps (tum_listing.h).

#include "panoscan/core/tum_listing.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "panoscan/core/error.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;

bool parse_timestamp(const std::string& token, double* value) {
  errno = 0;
  char* end = nullptr;
  const double parsed = std::strtod(token.c_str(), &end);
  if (token.empty() || end != token.c_str() + token.size() || errno == ERANGE || !std::isfinite(parsed)) return false;
  *value = parsed;
  return true;
}

}  // namespace

std::vector<TumListingEntry> read_tum_listing(const fs::path& listing_path, const fs::path& base_dir) {
  const std::string listing = listing_path.string();
  std::error_code ec;
  if (!fs::exists(listing_path, ec)) throw make_error(listing, "", "listing not found");
  if (fs::is_directory(listing_path, ec)) throw make_error(listing, "", "is a directory, expected a listing");
  std::ifstream in(listing_path);
  if (!in) throw make_error(listing, "", "cannot open listing for reading");

  std::vector<TumListingEntry> entries;
  std::string line;
  std::size_t line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string field = "line " + std::to_string(line_number);

    std::istringstream tokens(line);
    std::vector<std::string> parts;
    std::string token;
    while (tokens >> token) parts.push_back(token);
    if (parts.size() != 2) {
      throw make_error(listing, field,
                       "expected 'timestamp filename', found " + std::to_string(parts.size()) + " fields");
    }
    TumListingEntry entry;
    entry.timestamp_text = parts[0];
    entry.file = parts[1];
    entry.line_number = line_number;
    if (!parse_timestamp(parts[0], &entry.timestamp)) {
      throw make_error(listing, field, "timestamp '" + parts[0] + "' is not a finite number");
    }
    if (!entries.empty() && !(entry.timestamp > entries.back().timestamp)) {
      const char* problem = entry.timestamp == entries.back().timestamp ? "repeats" : "is before";
      throw make_error(listing, field,
                       "timestamp " + parts[0] + " " + problem + " the previous one (" + entries.back().timestamp_text +
                           ", line " + std::to_string(entries.back().line_number) +
                           "); timestamps must strictly increase");
    }
    if (!is_safe_relative_path(entry.file)) {
      throw make_error(listing, field,
                       "file name '" + entry.file + "' must be a path relative to " + base_dir.string());
    }
    const fs::path image_path = base_dir / entry.file;
    if (!fs::is_regular_file(image_path, ec)) {
      throw make_error(listing, field, "listed file not found: " + image_path.string());
    }
    entries.push_back(std::move(entry));
  }
  if (in.bad()) throw make_error(listing, "", "error while reading listing");
  if (entries.empty()) throw make_error(listing, "", "the listing holds no frames");
  return entries;
}

std::vector<TimestampPair> associate_timestamps(const std::vector<double>& rgb, const std::vector<double>& depth,
                                                double max_dt) {
  if (!std::isfinite(max_dt) || !(max_dt > 0.0)) {
    throw make_error("", "max_dt", "expected a finite positive number of seconds, found " + std::to_string(max_dt));
  }
  for (const std::vector<double>* list : {&rgb, &depth}) {
    for (std::size_t i = 1; i < list->size(); ++i) {
      if (!((*list)[i - 1] <= (*list)[i])) {
        throw make_error("", list == &rgb ? "rgb timestamps" : "depth timestamps", "not sorted ascending");
      }
    }
  }
  // Candidates within the window: for each colour timestamp the depth timestamps within max_dt are
  // a contiguous run of the sorted list, found by a pointer that only moves forward.
  std::vector<TimestampPair> candidates;
  std::size_t begin = 0;
  for (std::size_t r = 0; r < rgb.size(); ++r) {
    while (begin < depth.size() && !(depth[begin] - rgb[r] > -max_dt)) ++begin;
    for (std::size_t d = begin; d < depth.size() && depth[d] - rgb[r] < max_dt; ++d) {
      candidates.push_back({r, d, depth[d] - rgb[r]});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const TimestampPair& a, const TimestampPair& b) {
    const double da = std::abs(a.dt);
    const double db = std::abs(b.dt);
    if (da != db) return da < db;
    if (a.rgb != b.rgb) return a.rgb < b.rgb;
    return a.depth < b.depth;
  });
  std::vector<char> rgb_used(rgb.size(), 0);
  std::vector<char> depth_used(depth.size(), 0);
  std::vector<TimestampPair> pairs;
  for (const TimestampPair& candidate : candidates) {
    if (rgb_used[candidate.rgb] || depth_used[candidate.depth]) continue;
    rgb_used[candidate.rgb] = depth_used[candidate.depth] = 1;
    pairs.push_back(candidate);
  }
  std::sort(pairs.begin(), pairs.end(), [](const TimestampPair& a, const TimestampPair& b) { return a.rgb < b.rgb; });
  return pairs;
}

bool is_safe_relative_path(const std::string& text) {
  if (text.empty()) return false;
  const std::filesystem::path path(text);
  if (path.is_absolute() || path.has_root_name() || path.has_root_directory()) return false;
  for (const std::filesystem::path& part : path) {
    if (part == "..") return false;
  }
  return true;
}

}  // namespace panoscan
