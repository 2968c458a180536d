#include "panoscan/core/process.h"

#include <cstdlib>  // defines __GLIBC__ on glibc (through <features.h>)

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

#include <unistd.h>

#if defined(__GLIBC__)
#include <gnu/libc-version.h>
#endif

#include "panoscan/core/allocator.h"
#include "panoscan/core/log.h"

namespace panoscan {

std::string huge_page_heap_tunables(const char* current) {
  constexpr const char* kTunable = "glibc.malloc.hugetlb";
  const std::string tunables = current == nullptr ? "" : current;
  // Tunables are name=value pairs separated by ':'; a name is matched whole.
  std::size_t start = 0;
  while (start <= tunables.size()) {
    const std::size_t end = std::min(tunables.find(':', start), tunables.size());
    const std::string pair = tunables.substr(start, end - start);
    if (pair.compare(0, pair.find('='), kTunable) == 0) return "";
    start = end + 1;
  }
  return tunables.empty() ? std::string(kTunable) + "=1" : tunables + ":" + kTunable + "=1";
}

bool huge_page_heap_supported() {
#if defined(__GLIBC__) && defined(__linux__)
  int major = 0, minor = 0;
  if (std::sscanf(gnu_get_libc_version(), "%d.%d", &major, &minor) != 2) return false;
  if (major < 2 || (major == 2 && minor < 35)) return false;
  std::ifstream mode_file("/sys/kernel/mm/transparent_hugepage/enabled");
  const std::string mode((std::istreambuf_iterator<char>(mode_file)), std::istreambuf_iterator<char>());
  return mode.find("[always]") != std::string::npos || mode.find("[madvise]") != std::string::npos;
#else
  return false;
#endif
}

namespace {

// Valgrind runs a program with its preload libraries (vgpreload_*.so) in LD_PRELOAD. There,
// /proc/self/exe is valgrind's tool binary, which refuses to run on its own: re-executing would end
// the run (and valgrind replaces the allocator anyway).
bool under_valgrind() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload != nullptr && std::strstr(preload, "vgpreload") != nullptr;
}

// Adds the start-up settings the environment lacks and re-executes; returns only if there was nothing
// to add or the re-execution failed.
void reexecute_with_start_up_settings(char** argv) {
  bool reexecute = false;
  if (std::getenv("OMP_WAIT_POLICY") == nullptr) {
    ::setenv("OMP_WAIT_POLICY", "PASSIVE", 0);
    reexecute = true;
  }
  if (huge_page_heap_supported()) {
    const std::string tunables = huge_page_heap_tunables(std::getenv("GLIBC_TUNABLES"));
    if (!tunables.empty()) {
      ::setenv("GLIBC_TUNABLES", tunables.c_str(), 1);
      reexecute = true;
    }
  }
  if (!reexecute) return;
  // Both are in the environment now, so the re-executed process does not come here again.
  ::execv("/proc/self/exe", argv);
  log_warn(std::string("could not re-execute /proc/self/exe (") + std::strerror(errno) +
           "): running without the start-up settings of core/process.h");
}

}  // namespace

void set_up_process(char** argv) {
  if (!under_valgrind()) reexecute_with_start_up_settings(argv);
  keep_freed_memory_for_reuse();
}

}  // namespace panoscan
