// The drivers, one function per paper table or figure, each in its own source file.
// Add a driver: declare it here, list it in all_drivers() (drivers.cpp).
#pragma once

#include <vector>

#include "panoscan/tables/tables.h"

namespace panoscan::tables {

std::vector<TableDriver> all_drivers();

}  // namespace panoscan::tables
