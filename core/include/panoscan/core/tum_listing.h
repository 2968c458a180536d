// TUM RGB-D listings ("timestamp filename" per line, '#' starts a comment line): the one reader of
// the scan format's camK/rgb.txt and camK/depth.txt (docs/ARCHITECTURE.md §5) and of a TUM
// sequence's rgb.txt and depth.txt (`panoscan import tum`, tum_import.h), and the association of
// colour and depth images by nearest timestamp as TUM's associate.py does it.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace panoscan {

struct TumListingEntry {
  double timestamp = 0.0;
  std::string timestamp_text;  // as written, for messages and for file names
  std::string file;            // as written: relative to the listing's base folder
  std::size_t line_number = 0;  // 1-based line of the listing
};

// Reads `listing`. Each non-comment, non-blank line must hold exactly two fields, a finite
// timestamp and a relative path that stays inside `base_dir` (no "..", not absolute) naming a
// regular file under `base_dir`; timestamps strictly increase; at least one entry. Windows line
// ends are accepted. Throws Error "<listing>: line N: ..." (or "<listing>: ..." for a missing or
// empty listing).
std::vector<TumListingEntry> read_tum_listing(const std::filesystem::path& listing,
                                              const std::filesystem::path& base_dir);

// True when `text` is a relative path that stays inside the folder it is relative to (not empty,
// not absolute, no root, no ".." part): what listings and scan writers accept as a file name.
bool is_safe_relative_path(const std::string& text);

struct TimestampPair {
  std::size_t rgb = 0;    // index into the colour timestamps
  std::size_t depth = 0;  // index into the depth timestamps
  double dt = 0.0;        // depth - rgb, seconds
};

// Pairs colour and depth images as TUM's associate.py does: every pair with |depth - rgb| < max_dt
// is a candidate; candidates are taken greedily by smallest |dt| (ties: the earlier colour, then
// the earlier depth image), each timestamp used at most once. The result is sorted by the colour
// timestamp. Both inputs must be sorted ascending (listings are); max_dt must be finite and > 0.
std::vector<TimestampPair> associate_timestamps(const std::vector<double>& rgb, const std::vector<double>& depth,
                                                double max_dt);

}  // namespace panoscan
