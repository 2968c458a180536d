#include "panoscan/eval/coloured_cloud.h"

#include <algorithm>
#include <cstdio>

#include "panoscan/core/error.h"
#include "panoscan/eval/error_stats.h"

namespace panoscan::eval {

ColourLegend write_error_coloured_ply(const std::filesystem::path& path, const PointCloud& cloud,
                                      const std::vector<double>& distances, const ErrorColouring& colouring) {
  if (distances.size() != cloud.size())
    throw make_error(path.string(), "distances",
                     std::to_string(distances.size()) + " distances for " + std::to_string(cloud.size()) + " points");
  ColourLegend legend;
  legend.map = colouring.map;
  legend.min = colouring.min_m;
  legend.max = colouring.max_m;
  if (!(legend.max > legend.min)) {
    std::vector<double> sorted = distances;
    std::sort(sorted.begin(), sorted.end());
    legend.max = sorted.empty() ? legend.min + 1.0 : percentile_of_sorted(sorted, 0.99);
    if (!(legend.max > legend.min)) legend.max = legend.min + 1e-3;  // all distances equal
  }

  PointCloud coloured;
  coloured.positions = cloud.positions;
  coloured.normals = cloud.normals;
  coloured.variances = cloud.variances;
  coloured.colours.resize(cloud.size());
  std::vector<float> distance_values(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    coloured.colours[i] = legend.colour(distances[i]);
    distance_values[i] = static_cast<float>(distances[i]);
  }
  PlyWriteOptions options;
  char range[96];
  std::snprintf(range, sizeof range, "panoscan_colour_range_m %.9g %.9g", legend.min, legend.max);
  options.comments = {"panoscan error-coloured cloud: colour = distance to the ground-truth mesh, clamped",
                      std::string("panoscan_colour_map ") + to_string(legend.map), range};
  options.extra_properties.emplace_back("distance", std::move(distance_values));
  write_ply_point_cloud(path, coloured, options);
  return legend;
}

}  // namespace panoscan::eval
