// Internal to panoscan_recon_panorama (and its tests): the smoothed energy of Eq. 5 that fuse()
// minimises, with its gradient, at a given point: for checking the solver's assembled gradient
// (every term's stencil derivatives gathered into each unknown) against the energy itself.
#pragma once

#include <vector>

#include "panoscan/recon/panorama.h"

namespace panoscan::detail {

struct DepthEnergy {
  std::vector<double> x;         // the unknowns: one radial depth per pixel with measurements, in pixel order
  double smoothed = 0.0;         // the smoothed energy at x (data eps = options.data_epsilon_m)
  std::vector<double> gradient;  // its gradient
};

// At x, or at fuse()'s start (the per-pixel medians) when x is empty. The neighbours are coupled
// as fuse() couples them (by the start's depths). Throws for the method 'ave' (no energy) and if
// x has the wrong size.
DepthEnergy depth_energy(const PanoramaMeasurements& m, const FusionOptions& options, const std::vector<double>& x);

}  // namespace panoscan::detail
