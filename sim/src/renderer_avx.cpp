// The row passes of row_lanes.h with eight lanes: the one file of panoscan_sim compiled with -mavx
// (sim/CMakeLists.txt); renderer.cpp calls it only where the CPU has AVX.
#include "row_lanes.h"

namespace panoscan::render_rows {

void row_geometry_avx(RowScratch& row, int padded_width, const Eigen::Vector3f& origin, float inv_fx) {
  row_geometry_lanes<AvxLanes>(row, padded_width, origin, inv_fx);
}

void row_diffuse_avx(RowScratch& row, int padded_width, const LightArrays& lights) {
  row_diffuse_lanes<AvxLanes>(row, padded_width, lights);
}

}  // namespace panoscan::render_rows
