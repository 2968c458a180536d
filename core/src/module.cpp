#include "panoscan/core/module.h"

#include <dlfcn.h>

namespace panoscan {

void* load_module_symbol(const char* path, const char* symbol, std::string* error) {
  void* module = ::dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (module == nullptr) {
    *error = ::dlerror();
    return nullptr;
  }
  void* address = ::dlsym(module, symbol);
  if (address == nullptr) *error = ::dlerror();
  return address;
}

}  // namespace panoscan
