// Atomic output: everything PanoScan writes goes to a temporary name in the destination's
// folder first and is renamed into place when complete, so a killed run leaves no half file.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace panoscan {

// Writes `bytes` to `path` atomically. Throws Error naming the path on failure.
void write_file_atomic(const std::filesystem::path& path, const std::string& bytes);

// Calls `writer(temp_path)` to produce the file, then renames it to `path`. The temporary file
// is removed if the writer throws. Use for libraries that write files themselves (PNG, EXR).
void write_via_temp(const std::filesystem::path& path,
                    const std::function<void(const std::filesystem::path& temp_path)>& writer);

// Removes the temporary siblings of `path` (.<name>.tmp-<host>-<pid>-*) that a killed process of
// this host left behind (its pid no longer exists); returns how many. AtomicDirectory calls it
// before it writes, so the next run to the same place cleans up after a killed one (a scan, a
// panorama or a result folder; the files inside a folder are written inside its temporary
// sibling). Single files written with write_via_temp are not scanned for (a folder of thousands
// of frames would be listed at every write).
int remove_stale_temporaries(const std::filesystem::path& path);

// A directory built under a temporary sibling name and renamed into place by commit().
// If the object is destroyed without commit() the temporary directory is removed.
// If `final_path` exists and `overwrite` is false, the constructor throws.
class AtomicDirectory {
 public:
  AtomicDirectory(const std::filesystem::path& final_path, bool overwrite);
  ~AtomicDirectory();
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;

  const std::filesystem::path& temp_path() const { return temp_path_; }
  const std::filesystem::path& final_path() const { return final_path_; }
  void commit();

 private:
  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  bool overwrite_ = false;
  bool committed_ = false;
};

}  // namespace panoscan
