// The error-coloured cloud for MeshLab / CloudCompare: each point coloured by its distance to the
// ground-truth mesh, clamped to a legend range that is written into the PLY header as comments
// ("comment panoscan_colour_map viridis", "comment panoscan_colour_range_m 0 0.05") and returned.
// The distance itself is stored too, as the float property "distance" (a scalar field in
// CloudCompare).
#pragma once

#include <filesystem>
#include <vector>

#include "panoscan/core/point_cloud.h"
#include "panoscan/eval/colour_map.h"

namespace panoscan::eval {

struct ErrorColouring {
  ColourMap map = ColourMap::kViridis;
  double min_m = 0.0;
  double max_m = 0.05;  // <= min_m: use the 99th percentile of the distances
};

// Writes atomically. Throws Error naming the path if the sizes differ.
ColourLegend write_error_coloured_ply(const std::filesystem::path& path, const PointCloud& cloud,
                                      const std::vector<double>& distances, const ErrorColouring& colouring = {});

}  // namespace panoscan::eval
