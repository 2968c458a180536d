#include "panoscan/core/error.h"

namespace panoscan {

Error make_error(const std::string& file, const std::string& field, const std::string& what) {
  std::string message;
  if (!file.empty()) message += file + ": ";
  if (!field.empty()) message += field + ": ";
  message += what;
  return Error(message);
}

Refusal make_refusal(const std::string& file, const std::string& field, const std::string& what) {
  return Refusal(make_error(file, field, what).what());
}

}  // namespace panoscan
