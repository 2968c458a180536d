// Colour maps for error pictures (error-coloured clouds, panorama error images). Each map is a
// piecewise-linear interpolation through a few control colours of the published map, close to
// it but not bit-identical.
#pragma once

#include <string>

#include "panoscan/core/point_cloud.h"

namespace panoscan::eval {

enum class ColourMap {
  kViridis,   // perceptually uniform, dark purple (low) to yellow (high)
  kTurbo,     // rainbow-like, dark blue (low) to dark red (high)
  kCoolWarm,  // diverging, blue (negative) - grey (0) - red (positive), for signed errors
};

ColourMap parse_colour_map(const std::string& name);  // "viridis", "turbo", "coolwarm"; throws Error
const char* to_string(ColourMap map);

// Colour at t in [0, 1] (clamped; NaN gives black).
Rgb8 colour_at(ColourMap map, double t);

// What a picture's colours mean: value `min` maps to the first colour, `max` to the last,
// values outside are clamped.
struct ColourLegend {
  ColourMap map = ColourMap::kViridis;
  double min = 0.0;
  double max = 0.0;
  std::string unit = "m";

  Rgb8 colour(double value) const { return colour_at(map, max > min ? (value - min) / (max - min) : 0.0); }
  // "viridis 0 .. 0.05 m (clamped)"
  std::string describe() const;
};

}  // namespace panoscan::eval
