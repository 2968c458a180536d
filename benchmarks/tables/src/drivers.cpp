#include "drivers.h"

namespace panoscan::tables {

std::vector<TableDriver> all_drivers() {
  std::vector<TableDriver> drivers;
  // One line per driver, in the paper's order, e.g. drivers.push_back(table3_driver());
  drivers.push_back(table1_driver());
  drivers.push_back(table2_driver());
  drivers.push_back(table3_driver());
  drivers.push_back(table4_driver());
  drivers.push_back(table5_driver());
  drivers.push_back(fig8_driver());
  drivers.push_back(table6_driver());
  return drivers;
}

}  // namespace panoscan::tables
