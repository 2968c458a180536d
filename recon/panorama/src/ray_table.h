// Private to panoscan_recon_panorama: the unit rays of an equirectangular panorama's pixel
// centres from per-column and per-row tables (warping's rasteriser and the depth solver).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/camera.h"

namespace panoscan {

// The unit rays of the panorama's pixel centres, Equirectangular::direction(u, v) =
// (sin theta_v cos phi_u, sin theta_v sin phi_u, cos theta_v), from one table per column and one per
// row instead of a sine and a cosine per rasterised pixel. The factors are taken from direction()
// itself, at phi = 0 (cos 1, sin 0) and on the row with sin theta = 1, so that every product is the
// one direction() computes, bit for bit; where those two rows are not exact (they are for any H
// checked), every ray falls back to direction().
class RayTable {
 public:
  explicit RayTable(const Equirectangular& pano) : pano_(pano) {
    const int width = pano.width(), height = pano.height;
    const double equator_v = 0.5 * (height - 1);  // theta = pi/2
    exact_ = pano.direction(-0.5, equator_v).x() == 1.0;
    cos_phi_.resize(std::size_t(width));
    sin_phi_.resize(std::size_t(width));
    for (int u = 0; u < width && exact_; ++u) {
      const Eigen::Vector3d d = pano.direction(u, equator_v);
      cos_phi_[std::size_t(u)] = d.x();
      sin_phi_[std::size_t(u)] = d.y();
    }
    sin_theta_.resize(std::size_t(height));
    cos_theta_.resize(std::size_t(height));
    for (int v = 0; v < height && exact_; ++v) {
      const Eigen::Vector3d d = pano.direction(-0.5, v);  // phi = 0
      exact_ = exact_ && d.y() == 0.0;
      sin_theta_[std::size_t(v)] = d.x();
      cos_theta_[std::size_t(v)] = d.z();
    }
  }
  Eigen::Vector3d operator()(int u, int v) const {
    if (!exact_) return pano_.direction(u, v);
    const double st = sin_theta_[std::size_t(v)];
    return {st * cos_phi_[std::size_t(u)], st * sin_phi_[std::size_t(u)], cos_theta_[std::size_t(v)]};
  }

 private:
  Equirectangular pano_;
  bool exact_ = false;
  std::vector<double> cos_phi_, sin_phi_, sin_theta_, cos_theta_;
};

}  // namespace panoscan
