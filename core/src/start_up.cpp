#include "panoscan/core/start_up.h"

#include <cstdlib>  // defines __GLIBC__ on glibc (through <features.h>)

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>

#if defined(__GLIBC__)
#include <gnu/libc-version.h>
#endif

namespace panoscan {

bool add_start_up_settings() {
  bool added = false;
  if (std::getenv("OMP_WAIT_POLICY") == nullptr) {
    ::setenv("OMP_WAIT_POLICY", "PASSIVE", 0);
    added = true;
  }
  if (huge_page_heap_supported()) {
    const std::string tunables = huge_page_heap_tunables(std::getenv("GLIBC_TUNABLES"));
    if (!tunables.empty()) {
      ::setenv("GLIBC_TUNABLES", tunables.c_str(), 1);
      added = true;
    }
  }
  return added;
}

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

}  // namespace panoscan
