// Shared set-up of the accuracy gates: the quick size, the paper's noise, a scan cache in the
// build folder shared by all gate programs (file-locked, so ctest -j is safe), two threads so
// that the numbers are the same on every machine.
#pragma once

#include <filesystem>

#include "panoscan/tables/tables.h"

namespace panoscan::test {

// `texture`: the built-in rooms' density (scene.texture); the default, icl, is the paper's set-up.
inline tables::TablesOptions gate_options(const std::string& noise = "handa", const std::string& texture = "icl") {
  tables::TablesOptions options;
  options.size = "quick";
  options.noise = noise;
  options.texture = texture;
  options.cache = std::filesystem::path(PANOSCAN_BINARY_DIR) / "tables-cache";
  options.threads = 2;
  options.seed = 1;
  return options;
}

}  // namespace panoscan::test
