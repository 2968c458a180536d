// The drivers, one function per paper table or figure, each in its own source file
// src/<name>.cpp returning its TableDriver. Add a driver: declare it here and list it in
// all_drivers() (drivers.cpp), in the paper's order.
#pragma once

#include <vector>

#include "panoscan/tables/tables.h"

namespace panoscan {
class Config;
}

namespace panoscan::tables {

std::vector<TableDriver> all_drivers();

// The tracking the tables measure as "Ours" is the paper's graph: `recon track`'s defaults with
// track.depth_odometry off (that factor is beyond the paper; Table 2 measures it in rows of its own).
// Every driver that tracks sets this into the config it parses its tracking options from, so the
// records reproduce the paper's method whatever recon track's default becomes.
void use_papers_tracking_graph(Config& config);

// Declarations of the drivers (e.g. `TableDriver table3_driver();`), in the paper's order:
TableDriver table1_driver();
TableDriver table2_driver();
TableDriver table3_driver();
TableDriver table4_driver();
TableDriver table5_driver();
TableDriver fig8_driver();
TableDriver table6_driver();

}  // namespace panoscan::tables
