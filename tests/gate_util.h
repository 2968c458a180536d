// Shared set-up of the accuracy gates: the quick size, the paper's noise, a scan cache in the
// build folder shared by all gate programs (file-locked, so ctest -j is safe), two threads so
// that the numbers are the same on every machine.
#pragma once

#include <filesystem>

#include "panoscan/tables/tables.h"

namespace panoscan::test {

inline tables::TablesOptions gate_options(const std::string& noise = "handa") {
  tables::TablesOptions options;
  options.size = "quick";
  options.noise = noise;
  options.cache = std::filesystem::path(PANOSCAN_BINARY_DIR) / "tables-cache";
  options.threads = 2;
  options.seed = 1;
  return options;
}

}  // namespace panoscan::test
