// Modules this project builds and loads on first use (OpenCV's image decoders, Open3D): libraries
// that most processes never call, kept out of every program's start.
#pragma once

#include <string>

namespace panoscan {

// Loads the module at `path` (RTLD_NOW | RTLD_LOCAL: its libraries' symbols stay out of the
// program's global scope) and returns the address of `symbol`, or nullptr with the loader's reason
// in `error`. The module stays loaded.
void* load_module_symbol(const char* path, const char* symbol, std::string* error);

}  // namespace panoscan
