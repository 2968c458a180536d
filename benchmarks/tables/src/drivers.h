// The drivers, one function per paper table or figure, each in its own source file
// src/<name>.cpp returning its TableDriver. Add a driver: declare it here and list it in
// all_drivers() (drivers.cpp), in the paper's order.
#pragma once

#include <vector>

#include "panoscan/tables/tables.h"

namespace panoscan::tables {

std::vector<TableDriver> all_drivers();

// Declarations of the drivers (e.g. `TableDriver table3_driver();`), in the paper's order:
TableDriver table1_driver();
TableDriver table2_driver();
TableDriver table3_driver();
TableDriver table4_driver();
TableDriver table5_driver();
TableDriver fig8_driver();
TableDriver table6_driver();

}  // namespace panoscan::tables
