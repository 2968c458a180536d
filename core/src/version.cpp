#include "panoscan/core/version.h"

#ifndef PANOSCAN_VERSION
#error "PANOSCAN_VERSION is set by core/CMakeLists.txt"
#endif

namespace panoscan {

std::string project_version() { return PANOSCAN_VERSION; }

}  // namespace panoscan
