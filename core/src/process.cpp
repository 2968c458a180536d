#include "panoscan/core/process.h"

#include <cstdlib>  // defines __GLIBC__ on glibc (through <features.h>)

#include <cerrno>
#include <cstring>

#include <unistd.h>

#include "panoscan/core/allocator.h"
#include "panoscan/core/log.h"

namespace panoscan {

namespace {

// Valgrind runs a program with its preload libraries (vgpreload_*.so) in LD_PRELOAD. There,
// /proc/self/exe is valgrind's tool binary, which refuses to run on its own: re-executing would end
// the run (and valgrind replaces the allocator anyway).
bool under_valgrind() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload != nullptr && std::strstr(preload, "vgpreload") != nullptr;
}

// Adds the start-up settings the environment lacks and re-executes; returns only if there was nothing
// to add or the re-execution failed. (The panoscan command comes here with them already added by its
// launcher, app/launcher.cpp, and does not re-execute.)
void reexecute_with_start_up_settings(char** argv) {
  if (!add_start_up_settings()) return;
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
