// Colour maps as piecewise-linear curves through control colours read off the published maps
// (viridis: van der Walt & Smith 2015; turbo: Mikhailov 2019; cool-warm: Moreland 2009).

#include "panoscan/eval/colour_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "panoscan/core/error.h"

namespace panoscan::eval {

namespace {

struct ControlColour {
  double t;
  double r, g, b;
};

const ControlColour kViridis[] = {{0.000, 68, 1, 84},    {0.125, 71, 44, 122},  {0.250, 59, 82, 139},
                                  {0.375, 44, 114, 142}, {0.500, 33, 145, 140}, {0.625, 40, 174, 128},
                                  {0.750, 94, 201, 98},  {0.875, 170, 220, 50}, {1.000, 253, 231, 37}};
const ControlColour kTurbo[] = {{0.000, 48, 18, 59},   {0.125, 67, 103, 221}, {0.250, 38, 174, 233},
                                {0.375, 30, 228, 178}, {0.500, 149, 251, 81}, {0.625, 223, 221, 55},
                                {0.750, 254, 155, 45}, {0.875, 228, 70, 13},  {1.000, 122, 4, 3}};
const ControlColour kCoolWarm[] = {
    {0.00, 59, 76, 192}, {0.25, 141, 176, 254}, {0.50, 221, 221, 221}, {0.75, 244, 154, 123}, {1.00, 180, 4, 38}};

template <std::size_t N>
Rgb8 interpolate(const ControlColour (&colours)[N], double t) {
  t = std::clamp(t, 0.0, 1.0);
  std::size_t k = 1;
  while (k < N - 1 && colours[k].t < t) ++k;
  const ControlColour& lo = colours[k - 1];
  const ControlColour& hi = colours[k];
  const double s = (t - lo.t) / (hi.t - lo.t);
  auto channel = [&](double a, double b) { return static_cast<std::uint8_t>(std::lround(a + s * (b - a))); };
  return {channel(lo.r, hi.r), channel(lo.g, hi.g), channel(lo.b, hi.b)};
}

}  // namespace

ColourMap parse_colour_map(const std::string& name) {
  if (name == "viridis") return ColourMap::kViridis;
  if (name == "turbo") return ColourMap::kTurbo;
  if (name == "coolwarm") return ColourMap::kCoolWarm;
  throw make_error("", "colour map", "unknown colour map '" + name + "' (viridis, turbo, coolwarm)");
}

const char* to_string(ColourMap map) {
  switch (map) {
    case ColourMap::kViridis: return "viridis";
    case ColourMap::kTurbo: return "turbo";
    case ColourMap::kCoolWarm: return "coolwarm";
  }
  return "?";
}

Rgb8 colour_at(ColourMap map, double t) {
  if (std::isnan(t)) return {0, 0, 0};
  switch (map) {
    case ColourMap::kViridis: return interpolate(kViridis, t);
    case ColourMap::kTurbo: return interpolate(kTurbo, t);
    case ColourMap::kCoolWarm: return interpolate(kCoolWarm, t);
  }
  return {0, 0, 0};
}

std::string ColourLegend::describe() const {
  char text[160];
  std::snprintf(text, sizeof text, "%s %.6g .. %.6g %s (clamped)", to_string(map), min, max, unit.c_str());
  return text;
}

}  // namespace panoscan::eval
