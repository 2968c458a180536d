// The panoscan command as it is called: adds the start-up settings (core/start_up.h: OpenMP's
// passive wait, glibc's huge-page heap) to the environment and executes the program beside it,
// panoscan-main, with the same arguments. The program, which links PanoScan's libraries and their
// ~210 shared ones, is then loaded once; without the launcher it re-executes itself to get the
// settings, loading them twice (0.16 s of every call, against ~1 ms for this file's program).
// panoscan-main still runs on its own (valgrind, gdb), re-executing itself as before.
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>

#include <unistd.h>

#include "panoscan/core/start_up.h"

int main(int argc, char** argv) {
  panoscan::add_start_up_settings();
  // The program's path from this one's, symbolic links resolved: a link to the launcher elsewhere
  // (e.g. in ~/bin) still finds the build folder's program.
  char self[PATH_MAX];
  const ssize_t length = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (length <= 0) {
    std::fprintf(stderr, "panoscan: cannot find the program's folder: /proc/self/exe: %s\n", std::strerror(errno));
    return 2;
  }
  self[length] = '\0';
  std::string program(self);
  program.erase(program.rfind('/') + 1);
  program += "panoscan-main";
  // argv[0] is kept, so help and errors name the command as it was called.
  ::execv(program.c_str(), argv);
  std::fprintf(stderr, "panoscan: cannot run %s: %s\n", program.c_str(), std::strerror(errno));
  return 2;
}
