#include "panoscan/core/atomic_output.h"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <fstream>
#include <system_error>
#include <vector>

#include <signal.h>
#include <unistd.h>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"

namespace fs = std::filesystem;

namespace panoscan {

namespace {

// The host, in temporary names: a cache may be shared between machines, and a process id says
// whether the writer is alive only on its own host.
std::string host_name() {
  char name[256] = {0};
  if (::gethostname(name, sizeof(name) - 1) != 0 || name[0] == 0) return "host";
  std::string host(name);
  for (char& c : host)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '_';
  return host;
}

std::string temporary_prefix(const fs::path& path) { return "." + path.filename().string() + ".tmp-"; }

// A sibling name unique within this process and across processes and hosts (host, pid, counter):
// .<name>.tmp-<host>-<pid>-<counter>.
fs::path temporary_sibling(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const std::string name = temporary_prefix(path) + host_name() + "-" + std::to_string(::getpid()) + "-" +
                           std::to_string(counter.fetch_add(1));
  return parent / name;
}

void ensure_parent_exists(const fs::path& path) {
  const fs::path parent = path.parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw make_error(path.string(), "",
                     "cannot create the output folder " + parent.string() + ": " +
                         (ec ? ec.message() : std::string("not a directory")));
}

}  // namespace

int remove_stale_temporaries(const fs::path& path) {
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const std::string prefix = temporary_prefix(path) + host_name() + "-";
  std::error_code ec;
  fs::directory_iterator it(parent, ec);
  if (ec) return 0;
  std::vector<fs::path> stale;
  for (const fs::directory_entry& entry : it) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string rest = name.substr(prefix.size());  // <pid>-<counter>[.ext]
    const std::size_t dash = rest.find('-');
    if (dash == 0 || dash == std::string::npos) continue;
    long pid = 0;
    try {
      pid = std::stol(rest.substr(0, dash));
    } catch (...) {
      continue;
    }
    if (pid <= 0 || pid == long(::getpid())) continue;
    // Alive (or not ours to signal): leave it. Gone: a killed run's leftover.
    if (::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
    stale.push_back(entry.path());
  }
  int removed = 0;
  for (const fs::path& p : stale) {
    std::error_code remove_ec;
    fs::remove_all(p, remove_ec);
    if (!remove_ec) {
      ++removed;
      log_info("removed " + p.string() + ", left by a run that was killed while writing " + path.string());
    }
  }
  return removed;
}

void write_via_temp(const fs::path& path, const std::function<void(const fs::path&)>& writer) {
  ensure_parent_exists(path);
  // Keep the extension: image libraries pick the encoder from it.
  fs::path temp = temporary_sibling(path);
  temp += path.extension();
  try {
    writer(temp);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw;
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw make_error(path.string(), "", "cannot move the finished file into place: " + ec.message());
  }
}

void write_file_atomic(const fs::path& path, const std::string& bytes) {
  write_via_temp(path, [&](const fs::path& temp) {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw make_error(path.string(), "", "cannot open for writing");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) throw make_error(path.string(), "", "write failed (disk full?)");
  });
}

AtomicDirectory::AtomicDirectory(const fs::path& final_path, bool overwrite)
    : final_path_(final_path), overwrite_(overwrite) {
  std::error_code ec;
  if (fs::exists(final_path_, ec) && !overwrite_)
    throw make_error(final_path_.string(), "", "already exists (use --overwrite to replace it)");
  ensure_parent_exists(final_path_);
  remove_stale_temporaries(final_path_);
  temp_path_ = temporary_sibling(final_path_);
  fs::create_directory(temp_path_, ec);
  if (ec) throw make_error(final_path_.string(), "", "cannot create a directory beside it: " + ec.message());
}

AtomicDirectory::~AtomicDirectory() {
  if (!committed_) {
    std::error_code ignored;
    fs::remove_all(temp_path_, ignored);
  }
}

void AtomicDirectory::commit() {
  if (committed_) return;
  std::error_code ec;
  fs::path old_copy;
  if (fs::exists(final_path_, ec)) {
    if (!overwrite_) throw make_error(final_path_.string(), "", "appeared while writing; not replaced");
    // Move the old one aside first so that the final path is never half-written.
    old_copy = temporary_sibling(final_path_);
    fs::rename(final_path_, old_copy, ec);
    if (ec) throw make_error(final_path_.string(), "", "cannot move the old directory aside: " + ec.message());
  }
  fs::rename(temp_path_, final_path_, ec);
  if (ec) {
    if (!old_copy.empty()) {
      std::error_code ignored;
      fs::rename(old_copy, final_path_, ignored);
    }
    throw make_error(final_path_.string(), "", "cannot move the finished directory into place: " + ec.message());
  }
  committed_ = true;
  if (!old_copy.empty()) fs::remove_all(old_copy, ec);
}

}  // namespace panoscan
