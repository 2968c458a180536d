// What several command files share (app-internal; the public argument structs are in commands.h).
#pragma once

#include <string>
#include <vector>

#include "panoscan/core/config.h"

namespace panoscan::app {

// A config file (optional) plus "key=value" overrides.
Config load_config(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace panoscan::app
