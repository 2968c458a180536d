// What made an output: the project version and the source revision, for every JSON record.
#pragma once

#include <string>

namespace panoscan {

// CMake's PROJECT_VERSION, e.g. "0.1.0".
std::string project_version();
// `git describe --always --dirty` of the source tree at build time (a commit hash; with "-dirty-"
// and a hash of the uncommitted changes when the build had some, so that two edited states differ),
// or "unknown" when built outside a git checkout.
std::string source_revision();

}  // namespace panoscan
