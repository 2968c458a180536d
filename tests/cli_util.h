// Shared helpers for the tests that run the panoscan program: run it, check a one-line failure.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace panoscan::testutil {

struct RunResult {
  int exit_code = 0;
  std::string output;  // stdout and stderr
};

// Runs a shell command and collects its output (stdout and stderr) and exit code.
inline RunResult run_command(const std::string& command) {
  RunResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) {
    ADD_FAILURE() << "popen failed for: " << command;
    result.exit_code = -1;
    return result;
  }
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// Runs the program built beside the tests with `arguments` (shell words) and collects its output;
// `environment`: NAME=value words set for the run.
inline RunResult run_panoscan(const std::string& arguments, const std::string& environment = "") {
  return run_command((environment.empty() ? "" : "env " + environment + " ") + PANOSCAN_BINARY_DIR + "/app/panoscan " +
                     arguments);
}

// A failed run whose output names every needle (the file, the field, the reason).
inline void expect_failure_naming(const RunResult& r, const std::vector<std::string>& needles) {
  EXPECT_NE(r.exit_code, 0) << r.output;
  for (const auto& needle : needles)
    EXPECT_NE(r.output.find(needle), std::string::npos) << "missing '" << needle << "' in: " << r.output;
}

}  // namespace panoscan::testutil
