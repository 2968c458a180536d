#include "drivers.h"

#include "panoscan/core/config.h"

namespace panoscan::tables {

void use_papers_tracking_graph(Config& config) { config.set("track.depth_odometry", "false"); }

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
