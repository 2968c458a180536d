#include "drivers.h"

namespace panoscan::tables {

std::vector<TableDriver> all_drivers() {
  std::vector<TableDriver> drivers;
  return drivers;
}

}  // namespace panoscan::tables
