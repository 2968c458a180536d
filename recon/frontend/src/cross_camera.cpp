// Cross-camera correspondences in the narrow overlap band; see cross_camera.h.
#include "cross_camera.h"

#include "panoscan/core/log.h"

#include <algorithm>
#include <limits>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

namespace panoscan::cross_camera {
namespace {

// Patch half sizes along x and y for a relation (long along the band, short across it).
struct PatchShape {
  int half_x = 7, half_y = 2;
  int count() const { return (2 * half_x + 1) * (2 * half_y + 1); }
};
PatchShape patch_shape(const Relation& relation, const FrontendOptions& o) {
  const int long_half = o.band_patch_long_px / 2, short_half = o.band_patch_short_px / 2;
  return relation.along_x ? PatchShape{long_half, short_half} : PatchShape{short_half, long_half};
}

int search_radius_px(const ScanIndex& scan, const Relation& relation, const FrontendOptions& o) {
  const auto& in_b = scan.rig.sensors[relation.sensor_b].intrinsics;
  return std::max(1, int(std::ceil(std::max(in_b.fx, in_b.fy) * std::tan(deg2rad(o.band_search_deg)))));
}

// A corner of a with its zero-mean, unit-norm template and its patch warped into b's crop.
struct Anchor {
  Pixel pixel;
  float depth = 0;
  const float* templ = nullptr;     // the patch's template (BandCrop::templates), patch.count() values
  std::vector<cv::Point2f> warped;  // patch pixels in b's crop coordinates (at shift 0)
  cv::Point2f centre_in_b;          // the anchor itself, in b's full-image pixels
  double predicted_depth_in_b = 0;
};

// Template of the patch around `pixel` in a's crop into *templ; false if it leaves the crop, lacks
// depth, or is flatter than band_min_contrast (a plain wall gives no alignment).
bool make_template(const BandCrop& crop, Pixel pixel, const PatchShape& shape, const FrontendOptions& o,
                   float* depth, std::vector<float>* templ) {
  const int x0 = pixel.x - crop.roi.x, y0 = pixel.y - crop.roi.y;
  if (x0 - shape.half_x < 0 || y0 - shape.half_y < 0 || x0 + shape.half_x >= crop.gray.width ||
      y0 + shape.half_y >= crop.gray.height)
    return false;
  const float z = crop.depth.at(x0, y0);
  if (!(z >= o.min_depth_m && z <= o.max_depth_m)) return false;
  *depth = z;
  templ->clear();
  double sum = 0;
  for (int j = -shape.half_y; j <= shape.half_y; ++j)
    for (int i = -shape.half_x; i <= shape.half_x; ++i) {
      const float g = crop.gray.at(x0 + i, y0 + j);
      templ->push_back(g);
      sum += g;
    }
  const double mean = sum / templ->size();
  double squares = 0;
  for (float& g : *templ) {
    g = float(g - mean);
    squares += double(g) * g;
  }
  const double std_dev = std::sqrt(squares / templ->size());
  if (std_dev < o.band_min_contrast) return false;
  // Both directions must be textured: an edge or a shading ramp (one eigenvalue of the structure
  // tensor near zero) correlates equally well all along itself, and in a band a few pixels high
  // that ambiguity cannot be seen by the search. Central differences inside the patch.
  const int w = 2 * shape.half_x + 1, h = 2 * shape.half_y + 1;
  auto at = [&](int i, int j) { return double((*templ)[std::size_t(j) * w + i]); };
  double sxx = 0, syy = 0, sxy = 0;
  int n = 0;
  for (int j = 1; j + 1 < h; ++j)
    for (int i = 1; i + 1 < w; ++i) {
      const double gx = 0.5 * (at(i + 1, j) - at(i - 1, j)), gy = 0.5 * (at(i, j + 1) - at(i, j - 1));
      sxx += gx * gx, syy += gy * gy, sxy += gx * gy;
      ++n;
    }
  if (n == 0) return false;
  sxx /= n, syy /= n, sxy /= n;
  const double min_eigen = 0.5 * (sxx + syy) - std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
  if (min_eigen < o.band_min_gradient * o.band_min_gradient) return false;
  const float inverse_norm = float(1.0 / std::sqrt(squares));
  for (float& g : *templ) g *= inverse_norm;
  return true;
}

// The anchor of crop a's patch k (its pixel, depth and template; warp_anchor adds the rest).
void set_anchor(const BandCrop& crop_a, std::size_t k, Anchor* anchor) {
  anchor->pixel = crop_a.patches[k].pixel;
  anchor->depth = crop_a.patches[k].depth;
  anchor->templ = crop_a.templates.data() + k * std::size_t(crop_a.patch_pixels);
}

// Warps the anchor's patch into b, every patch pixel at the anchor's depth. The depth matters for
// where the patch lands (the cameras are centimetres apart: 6 cm shift a point 2.5 m away by 14 px
// at 570 px focal length) but hardly within a patch of a few pixels. False as well when no shift
// within `radius` can bring the patch inside b's crop: the anchor itself is one of the patch's
// pixels, so when it stays outside at every shift, correlation_surface would score none (most
// anchors land outside b's crop, and warping their patches was a tenth of the band's search).
bool warp_anchor(const Relation& relation, const Rigid3d& b_from_a, const ScanIndex& scan, const BandCrop& crop_b,
                 const PatchShape& shape, int radius, Anchor* anchor) {
  const auto& in_a = scan.rig.sensors[relation.sensor_a].intrinsics;
  const auto& in_b = scan.rig.sensors[relation.sensor_b].intrinsics;
  const Eigen::Vector3d centre = b_from_a * in_a.backproject(anchor->pixel.x, anchor->pixel.y, anchor->depth);
  if (centre.z() <= 0.05) return false;
  const Eigen::Vector2d centre_px = in_b.project(centre);
  anchor->centre_in_b = cv::Point2f(float(centre_px.x()), float(centre_px.y()));
  // The anchor's own warped position (as the loop below stores it) against correlation_surface's
  // range test.
  const double centre_x = float(centre_px.x() - crop_b.roi.x), centre_y = float(centre_px.y() - crop_b.roi.y);
  if (centre_x + radius < 0 || centre_y + radius < 0 || centre_x - radius > double(crop_b.gray.width - 1) - 1e-3 ||
      centre_y - radius > double(crop_b.gray.height - 1) - 1e-3)
    return false;
  anchor->predicted_depth_in_b = centre.z();
  anchor->warped.clear();
  // At one depth the back-projected patch is linear in the pixel offsets: the point of offset
  // (i, j) is centre + i step_u + j step_v in b.
  const Eigen::Vector3d step_u = b_from_a.linear().col(0) * (anchor->depth / in_a.fx);
  const Eigen::Vector3d step_v = b_from_a.linear().col(1) * (anchor->depth / in_a.fy);
  for (int j = -shape.half_y; j <= shape.half_y; ++j)
    for (int i = -shape.half_x; i <= shape.half_x; ++i) {
      const Eigen::Vector3d p = centre + double(i) * step_u + double(j) * step_v;
      if (p.z() <= 0.05) return false;
      const Eigen::Vector2d px = in_b.project(p);
      anchor->warped.emplace_back(float(px.x() - crop_b.roi.x), float(px.y() - crop_b.roi.y));
    }
  return true;
}

// The anchor's warped patch in b's crop as integer pixel offsets and bilinear weights at shift 0.
// The search only shifts the patch by whole pixels, so the weights stay the same at every shift:
// computed once per anchor instead of once per shift (the search scored up to (2r+1)^2 shifts of
// every anchor, a fifth of the whole front end's instructions).
struct PatchSampler {
  std::vector<std::ptrdiff_t> offset;  // iy * stride + ix of each patch pixel's top-left neighbour
  std::vector<float> w00, w01, w10, w11;
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;  // extent of the warped positions
};

void prepare_sampler(const Anchor& anchor, const ImageF32& gray_b, PatchSampler* sampler) {
  const std::size_t n = anchor.warped.size();
  const std::ptrdiff_t stride = std::ptrdiff_t(gray_b.width) * gray_b.channels;
  sampler->offset.resize(n);
  sampler->w00.resize(n), sampler->w01.resize(n), sampler->w10.resize(n), sampler->w11.resize(n);
  sampler->min_x = sampler->min_y = std::numeric_limits<double>::infinity();
  sampler->max_x = sampler->max_y = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < n; ++k) {
    const float x = anchor.warped[k].x, y = anchor.warped[k].y;
    // floor without a libm call (the x86-64 baseline has no SSE4.1 rounding instruction).
    const int x_int = int(x), y_int = int(y);
    const float ix = float(x_int - (float(x_int) > x)), iy = float(y_int - (float(y_int) > y));
    const float fx = x - ix, fy = y - iy;
    sampler->offset[k] = std::ptrdiff_t(iy) * stride + std::ptrdiff_t(ix);
    sampler->w00[k] = (1 - fy) * (1 - fx), sampler->w01[k] = (1 - fy) * fx;
    sampler->w10[k] = fy * (1 - fx), sampler->w11[k] = fy * fx;
    sampler->min_x = std::min(sampler->min_x, double(x)), sampler->max_x = std::max(sampler->max_x, double(x));
    sampler->min_y = std::min(sampler->min_y, double(y)), sampler->max_y = std::max(sampler->max_y, double(y));
  }
}

// Normalised cross-correlation of the anchor's template with b's crop sampled (bilinearly) at the
// warped patch shifted by the whole pixels (dx, dy), at every shift in [-radius, radius]^2, into
// `surface` (row-major, dy outer; -2 where the patch leaves the crop). Returns the index of the
// first highest score, -1 when no shift keeps the patch inside. The loops run patch pixel by patch
// pixel with the shifts inside: for one pixel and one row of shifts the samples are a contiguous
// run of b's row, so the loop over dx vectorises (shift by shift, as before, the search was 17% of
// a tracking run's instructions). The sums are single precision, four shifts per SSE instruction
// (double precision took two and converted every sample twice; the band's first search was then
// 14% of the front end's instructions). Single precision holds because the samples are taken
// relative to a grey level of the searched region: what is summed is the patch's contrast (tens of
// grey levels over 21 x 3 pixels), not its brightness, so the variance loses no digits to the mean.
// Per-shift sums of correlation_surface, kept by the caller across anchors (no allocation per anchor).
struct CorrelationSums {
  std::vector<float> sums, squares, cross;
};

int correlation_surface(const Anchor& anchor, const PatchSampler& sampler, const ImageF32& gray_b, int radius,
                        std::vector<double>* surface, CorrelationSums* scratch) {
  const int side = 2 * radius + 1;
  surface->assign(std::size_t(side) * side, -2.0);
  // The patch stays inside the crop: a test that separates into x and y, each true on one interval.
  const double max_x = double(gray_b.width - 1) - 1e-3, max_y = double(gray_b.height - 1) - 1e-3;
  int dx_lo = radius + 1, dx_hi = -radius - 1, dy_lo = radius + 1, dy_hi = -radius - 1;
  for (int d = -radius; d <= radius; ++d) {
    if (sampler.min_x + d >= 0 && sampler.max_x + d <= max_x) dx_lo = std::min(dx_lo, d), dx_hi = std::max(dx_hi, d);
    if (sampler.min_y + d >= 0 && sampler.max_y + d <= max_y) dy_lo = std::min(dy_lo, d), dy_hi = std::max(dy_hi, d);
  }
  if (dx_lo > dx_hi || dy_lo > dy_hi) return -1;
  const int nx = dx_hi - dx_lo + 1, ny = dy_hi - dy_lo + 1;
  const std::size_t cells = std::size_t(nx) * ny;
  scratch->sums.assign(cells, 0.f);
  scratch->squares.assign(cells, 0.f);
  scratch->cross.assign(cells, 0.f);
  std::vector<float>& sums = scratch->sums;
  std::vector<float>& squares = scratch->squares;
  std::vector<float>& cross = scratch->cross;
  const std::size_t n = anchor.warped.size();
  const std::ptrdiff_t stride = std::ptrdiff_t(gray_b.width) * gray_b.channels;
  const float* image = gray_b.row(0);
  // The reference grey level: b at the patch's middle pixel, shifted to the middle of the searched
  // shifts (inside the crop by the range test above).
  const float reference =
      image[sampler.offset[n / 2] + std::ptrdiff_t((dy_lo + dy_hi) / 2) * stride + (dx_lo + dx_hi) / 2];
  for (std::size_t k = 0; k < n; ++k) {
    const float w00 = sampler.w00[k], w01 = sampler.w01[k], w10 = sampler.w10[k], w11 = sampler.w11[k];
    const float t = anchor.templ[k];
    for (int dy = dy_lo; dy <= dy_hi; ++dy) {
      const float* p = image + sampler.offset[k] + std::ptrdiff_t(dy) * stride + dx_lo;
      const std::size_t row = std::size_t(dy - dy_lo) * nx;
      float* __restrict s = sums.data() + row;
      float* __restrict q = squares.data() + row;
      float* __restrict c = cross.data() + row;
      for (int i = 0; i < nx; ++i) {
        const float g = w00 * p[i] + w01 * p[i + 1] + w10 * p[i + stride] + w11 * p[i + stride + 1] - reference;
        s[i] += g;
        q[i] += g * g;
        c[i] += g * t;
      }
    }
  }
  int best = -1;
  for (int dy = dy_lo; dy <= dy_hi; ++dy)
    for (int dx = dx_lo; dx <= dx_hi; ++dx) {
      const std::size_t cell = std::size_t(dy - dy_lo) * nx + std::size_t(dx - dx_lo);
      const double variance = double(squares[cell]) - double(sums[cell]) * double(sums[cell]) / double(n);
      const int index = (dy + radius) * side + dx + radius;
      (*surface)[std::size_t(index)] = variance > 1e-6 ? double(cross[cell]) / std::sqrt(variance) : 0.0;
      if (best < 0 || (*surface)[std::size_t(index)] > (*surface)[std::size_t(best)]) best = index;
    }
  return best;
}

// Vertex offset of the parabola through (-1, a), (0, b), (1, c), in [-0.5, 0.5].
double parabola_peak(double a, double b, double c) {
  const double denominator = a - 2 * b + c;
  if (!(denominator < 0)) return 0.0;
  return std::clamp(0.5 * (a - c) / denominator, -0.5, 0.5);
}

// A correlation peak the data can pin down in both directions: its four neighbours scored (for the
// sub-pixel fit), and in each direction at least one shift two pixels away scored and lower by
// `margin`. In a band a few rows high most shifts across it leave the other image; a peak whose
// neighbourhood across the band cannot be scored says nothing about where across the band the
// patch belongs (at the default rig such votes made a wrong calibration correction win).
bool is_distinct_peak(const std::vector<double>& surface, int side, int best, double margin) {
  const int bx = best % side, by = best / side;
  if (bx < 2 || by < 2 || bx > side - 3 || by > side - 3) return false;
  constexpr double kInvalid = -1.5;  // unscored shifts hold -2
  if (std::min({surface[best - 1], surface[best + 1], surface[best - side], surface[best + side]}) < kInvalid)
    return false;
  const double peak = surface[best];
  for (const int step : {1, side}) {  // along x, then along y
    const double before = surface[best - 2 * step], after = surface[best + 2 * step];
    if (before < kInvalid && after < kInvalid) return false;
    if (std::max(before, after) > peak - margin) return false;
  }
  return true;
}

Eigen::Vector3d ray(const PinholeIntrinsics& in, double x, double y) { return in.backproject(x, y, 1.0).normalized(); }

}  // namespace

std::vector<Relation> overlapping_relations(const ScanIndex& scan, const std::vector<char>& used,
                                            const FrontendOptions& options) {
  std::vector<Relation> relations;
  const int sensor_count = int(scan.rig.sensors.size());
  for (int a = 0; a < sensor_count; ++a)
    for (int b = a + 1; b < sensor_count; ++b) {
      if (!used[a] || !used[b]) continue;
      Relation relation;
      relation.sensor_a = a;
      relation.sensor_b = b;
      relation.b_from_a_calibrated = scan.rig.sensors[b].ref_from_cam.inverse() * scan.rig.sensors[a].ref_from_cam;
      const auto& in_a = scan.rig.sensors[a].intrinsics;
      const auto& in_b = scan.rig.sensors[b].intrinsics;
      const int margin = search_radius_px(scan, relation, options) +
                         std::max(options.band_patch_long_px, options.band_patch_short_px) / 2 + 2;
      // Pixels of a that see into b (widened by the search margin) at depths spanning a room.
      int ax0 = in_a.width, ay0 = in_a.height, ax1 = -1, ay1 = -1;
      int bx0 = in_b.width, by0 = in_b.height, bx1 = -1, by1 = -1;
      for (double depth : {0.7, 1.5, 3.0, 6.0})
        for (int v = 0; v < in_a.height; v += 2)
          for (int u = 0; u < in_a.width; u += 2) {
            const Eigen::Vector3d p = relation.b_from_a_calibrated * in_a.backproject(u, v, depth);
            if (p.z() <= 0.05) continue;
            const Eigen::Vector2d px = in_b.project(p);
            if (px.x() < -margin || px.y() < -margin || px.x() > in_b.width - 1 + margin ||
                px.y() > in_b.height - 1 + margin)
              continue;
            ax0 = std::min(ax0, u), ay0 = std::min(ay0, v), ax1 = std::max(ax1, u), ay1 = std::max(ay1, v);
            const int bx = std::clamp(int(std::lround(px.x())), 0, in_b.width - 1);
            const int by = std::clamp(int(std::lround(px.y())), 0, in_b.height - 1);
            bx0 = std::min(bx0, bx), by0 = std::min(by0, by), bx1 = std::max(bx1, bx), by1 = std::max(by1, by);
          }
      if (ax1 < 0) continue;  // the two views never meet
      log_debug(fmt::format("band cam{}-cam{}: region of a x {}-{} y {}-{}, of b x {}-{} y {}-{} (margin {} px)", a, b,
                            ax0, ax1, ay0, ay1, bx0, bx1, by0, by1, margin));
      auto widened = [margin](int x0, int y0, int x1, int y1, const PinholeIntrinsics& in) {
        const int left = std::max(0, x0 - margin), top = std::max(0, y0 - margin);
        const int right = std::min(in.width - 1, x1 + margin), bottom = std::min(in.height - 1, y1 + margin);
        return PixelRect{left, top, right - left + 1, bottom - top + 1};
      };
      relation.roi_a = widened(ax0, ay0, ax1, ay1, in_a);
      relation.roi_b = widened(bx0, by0, bx1, by1, in_b);
      relation.along_x = relation.roi_a.width >= relation.roi_a.height;
      relations.push_back(relation);
    }
  return relations;
}

BandCrop make_band_crop(const RgbdFrame& frame, const Relation& relation, bool camera_a,
                        const FrontendOptions& options) {
  const PixelRect& roi = camera_a ? relation.roi_a : relation.roi_b;
  BandCrop crop;
  crop.roi = roi;
  const cv::Rect rect(roi.x, roi.y, roi.width, roi.height);
  const cv::Mat rgb(frame.rgb.height, frame.rgb.width, CV_8UC3, const_cast<std::uint8_t*>(frame.rgb.data.data()));
  const cv::Mat depth(frame.depth.height, frame.depth.width, CV_32F, const_cast<float*>(frame.depth.data.data()));
  crop.gray = ImageF32(roi.width, roi.height);
  crop.depth = ImageF32(roi.width, roi.height);
  cv::Mat grey_u8;
  cv::cvtColor(rgb(rect), grey_u8, cv::COLOR_RGB2GRAY);
  cv::Mat gray(roi.height, roi.width, CV_32F, crop.gray.data.data());  // writes into crop.gray
  grey_u8.convertTo(gray, CV_32F);
  cv::Mat depth_crop(roi.height, roi.width, CV_32F, crop.depth.data.data());  // writes into crop.depth
  depth(rect).copyTo(depth_crop);
  if (!camera_a) return crop;
  // Corners: 3x3 local maxima of the minimum eigenvalue of the structure tensor, strongest first.
  cv::Mat eigen;
  cv::cornerMinEigenVal(gray, eigen, 3, 3);
  std::vector<std::pair<float, Pixel>> maxima;
  for (int y = 1; y + 1 < eigen.rows; ++y)
    for (int x = 1; x + 1 < eigen.cols; ++x) {
      const float e = eigen.at<float>(y, x);
      if (!(e > 0)) continue;
      bool is_max = true;
      for (int j = -1; j <= 1 && is_max; ++j)
        for (int i = -1; i <= 1; ++i)
          if ((i || j) && eigen.at<float>(y + j, x + i) > e) {
            is_max = false;
            break;
          }
      if (is_max) maxima.push_back({e, Pixel{x + roi.x, y + roi.y}});
    }
  std::stable_sort(maxima.begin(), maxima.end(), [](const auto& l, const auto& r) { return l.first > r.first; });
  const std::size_t keep = std::min<std::size_t>(maxima.size(), std::size_t(options.band_max_corners));
  for (std::size_t k = 0; k < keep; ++k) crop.corners.push_back(maxima[k].second);
  const PatchShape shape = patch_shape(relation, options);
  crop.patch_pixels = shape.count();
  std::vector<float> templ;
  for (const Pixel& corner : crop.corners) {
    float z = 0;
    if (!make_template(crop, corner, shape, options, &z, &templ)) continue;
    crop.patches.push_back({corner, z});
    crop.templates.insert(crop.templates.end(), templ.begin(), templ.end());
  }
  crop.gray = ImageF32();
  crop.depth = ImageF32();
  return crop;
}

bool CameraChains::motion(int sensor, double t1, double t2, Rigid3d* cam1_from_cam2) const {
  const std::vector<double>& t = timestamps[sensor];
  auto pose_at = [&](double time, Rigid3d* chain_from_cam, int* chain) {
    if (t.empty() || time < t.front() || time > t.back()) return false;
    const std::size_t hi = std::size_t(std::lower_bound(t.begin(), t.end(), time) - t.begin());
    if (t[hi] == time) {
      *chain = chain_of_frame[sensor][hi];
      *chain_from_cam = chain_from_frame[sensor][hi];
      return *chain >= 0;
    }
    const std::size_t lo = hi - 1;  // t[lo] < time < t[hi]
    *chain = chain_of_frame[sensor][lo];
    if (*chain < 0 || chain_of_frame[sensor][hi] != *chain) return false;
    const double s = (time - t[lo]) / (t[hi] - t[lo]);
    const Rigid3d& p0 = chain_from_frame[sensor][lo];
    const Rigid3d step = p0.inverse() * chain_from_frame[sensor][hi];
    *chain_from_cam = p0 * make_rigid(so3_exp(s * so3_log(step.linear())), s * step.translation());
    return true;
  };
  Rigid3d p1, p2;
  int c1 = -1, c2 = -1;
  if (!pose_at(t1, &p1, &c1) || !pose_at(t2, &p2, &c2) || c1 != c2) return false;
  *cam1_from_cam2 = p1.inverse() * p2;
  return true;
}

bool predict_b_from_a(const CameraChains& chains, const Relation& relation, const Rigid3d& b_from_a_at_one_instant,
                      int frame_a, int frame_b, Rigid3d* b_from_a) {
  const double ta = chains.timestamps[relation.sensor_a][frame_a];
  const double tb = chains.timestamps[relation.sensor_b][frame_b];
  const Rigid3d a_from_b_at_one_instant = b_from_a_at_one_instant.inverse();
  Rigid3d motion;
  if (chains.motion(relation.sensor_a, ta, tb, &motion)) {  // cam_a(ta)_from_cam_a(tb)
    *b_from_a = (motion * a_from_b_at_one_instant).inverse();
    return true;
  }
  if (chains.motion(relation.sensor_b, ta, tb, &motion)) {  // cam_b(ta)_from_cam_b(tb)
    *b_from_a = (a_from_b_at_one_instant * motion).inverse();
    return true;
  }
  return false;
}

Eigen::Matrix3d estimate_band_correction(const Relation& relation, const CameraChains& chains,
                                         const std::vector<std::pair<int, int>>& frame_pairs,
                                         const std::vector<const BandCrop*>& crops_a,
                                         const std::vector<const BandCrop*>& crops_b, const ScanIndex& scan,
                                         const FrontendOptions& options, int* agreeing_votes) {
  *agreeing_votes = 0;
  const int radius = search_radius_px(scan, relation, options);
  const int side = 2 * radius + 1;
  const PatchShape shape = patch_shape(relation, options);
  const auto& in_b = scan.rig.sensors[relation.sensor_b].intrinsics;
  // Each anchor votes for the shift of its own distinct correlation peak: summing correlations
  // instead lets shifts that put more patches inside b, and ramps (which correlate at any shift
  // along them), win.
  struct Vote {
    int frame_a;                       // the frame of a that voted
    Eigen::Vector2d shift, predicted;  // sub-pixel shift; predicted position in b
  };
  std::vector<std::vector<Vote>> per_pair(frame_pairs.size());
  tbb::parallel_for(std::size_t(0), frame_pairs.size(), [&](std::size_t k) {
    Rigid3d b_from_a;
    if (!predict_b_from_a(chains, relation, relation.b_from_a_calibrated, frame_pairs[k].first, frame_pairs[k].second,
                          &b_from_a))
      return;
    const BandCrop& crop_a = *crops_a[k];
    const BandCrop& crop_b = *crops_b[k];
    Anchor anchor;
    PatchSampler sampler;
    CorrelationSums sums;
    std::vector<double> surface(std::size_t(side) * side);
    for (std::size_t patch = 0; patch < crop_a.patches.size(); ++patch) {
      set_anchor(crop_a, patch, &anchor);
      if (!warp_anchor(relation, b_from_a, scan, crop_b, shape, radius, &anchor)) continue;
      prepare_sampler(anchor, crop_b.gray, &sampler);
      const int best = correlation_surface(anchor, sampler, crop_b.gray, radius, &surface, &sums);
      if (best < 0) continue;
      const int bx = best % side, by = best / side;
      if (surface[best] < options.band_min_ncc || !is_distinct_peak(surface, side, best, options.band_peak_margin))
        continue;
      // ... and distinct from every shift more than two pixels away.
      const double left = surface[best - 1], right = surface[best + 1];
      const double up = surface[best - side], down = surface[best + side];
      double runner_up = -1.0;
      for (int i = 0; i < side * side; ++i)
        if (std::max(std::abs(i % side - bx), std::abs(i / side - by)) > 2) runner_up = std::max(runner_up, surface[i]);
      if (surface[best] - runner_up < options.band_peak_margin) continue;
      const Eigen::Vector2d shift(bx - radius + parabola_peak(left, surface[best], right),
                                  by - radius + parabola_peak(up, surface[best], down));
      per_pair[k].push_back({frame_pairs[k].first, shift, Eigen::Vector2d(anchor.centre_in_b.x, anchor.centre_in_b.y)});
    }
  });
  std::vector<Vote> votes;
  for (const auto& pair_votes : per_pair)  // fixed order: independent of the thread count
    votes.insert(votes.end(), pair_votes.begin(), pair_votes.end());
  // The rotation most votes agree with (within 1 px): each vote is a predicted and an observed
  // direction in b; every two votes give a hypothesis (all pairs, so no random draws), scored by
  // the votes it explains. A second hypothesis more than 3 px away at the band's centre must
  // explain clearly fewer (band_peak_ratio), or the band is ambiguous and nothing is corrected.
  std::vector<Eigen::Vector3d> predicted_rays, observed_rays;
  for (const Vote& v : votes) {
    predicted_rays.push_back(ray(in_b, v.predicted.x(), v.predicted.y()));
    observed_rays.push_back(ray(in_b, v.predicted.x() + v.shift.x(), v.predicted.y() + v.shift.y()));
  }
  const double focal = std::max(in_b.fx, in_b.fy);
  // Votes of one rotation spread by 2-3 px: the rig's motion between the shutter times is predicted
  // per frame pair from the chains, with errors of 0.1-0.2 deg.
  constexpr double kVoteTolerancePx = 2.0;
  auto explained = [&](const Eigen::Matrix3d& rotation, std::vector<int>* inliers) {
    int count = 0;
    for (std::size_t i = 0; i < votes.size(); ++i) {
      const Eigen::Vector3d p = rotation * predicted_rays[i];
      const double error_px = focal * (p - observed_rays[i]).norm();
      if (error_px <= kVoteTolerancePx) {
        ++count;
        if (inliers) inliers->push_back(int(i));
      }
    }
    return count;
  };
  struct Hypothesis {
    Eigen::Matrix3d rotation;
    int votes;
  };
  // Hypotheses from pairs of a fixed, evenly spread subset of at most 80 votes (deterministic).
  std::vector<Hypothesis> hypotheses;
  const std::size_t stride = std::max<std::size_t>(1, votes.size() / 80);
  for (std::size_t i = 0; i < votes.size(); i += stride)
    for (std::size_t j = i + stride; j < votes.size(); j += stride) {
      if ((votes[i].predicted - votes[j].predicted).norm() < 20.0) continue;  // too close to fix the roll
      const Eigen::Matrix3d m =
          observed_rays[i] * predicted_rays[i].transpose() + observed_rays[j] * predicted_rays[j].transpose();
      const Eigen::Matrix3d rotation = closest_rotation(m);
      if (rad2deg(rotation_angle(rotation)) > 2.0 * options.band_search_deg) continue;
      hypotheses.push_back({rotation, explained(rotation, nullptr)});
    }
  std::stable_sort(hypotheses.begin(), hypotheses.end(),
                   [](const Hypothesis& l, const Hypothesis& r) { return l.votes > r.votes; });
  if (hypotheses.empty()) return Eigen::Matrix3d::Identity();
  std::vector<int> inliers;
  explained(hypotheses.front().rotation, &inliers);
  // The runner-up: the best hypothesis more than twice the tolerance away at the image centre that
  // explains mostly other votes (a different explanation, not the same cluster seen through a
  // slightly different rotation).
  std::vector<char> is_inlier(votes.size(), 0);
  for (int i : inliers) is_inlier[i] = 1;
  int runner_up = 0;
  const Eigen::Vector3d centre = Eigen::Vector3d::UnitZ();
  for (std::size_t h = 1; h < hypotheses.size() && hypotheses[h].votes > runner_up; ++h) {
    if (focal * (hypotheses[h].rotation * centre - hypotheses.front().rotation * centre).norm() <=
        2.0 * kVoteTolerancePx)
      continue;
    std::vector<int> other;
    explained(hypotheses[h].rotation, &other);
    const long shared = std::count_if(other.begin(), other.end(), [&](int i) { return is_inlier[i] != 0; });
    if (shared <= 0.2 * double(other.size())) runner_up = int(other.size());
  }
  std::vector<int> frames_voting, frames_agreeing;
  for (const Vote& v : votes) frames_voting.push_back(v.frame_a);
  for (int i : inliers) frames_agreeing.push_back(votes[i].frame_a);
  auto distinct = [](std::vector<int> f) {
    std::sort(f.begin(), f.end());
    return int(std::unique(f.begin(), f.end()) - f.begin());
  };
  log_debug(
      fmt::format("band cam{}-cam{}: {} votes from {} frames, {} from {} frames agree on a {:.2f}-deg "
                  "correction, runner-up {}",
                  relation.sensor_a, relation.sensor_b, votes.size(), distinct(frames_voting), inliers.size(),
                  distinct(frames_agreeing), rad2deg(rotation_angle(hypotheses.front().rotation)), runner_up));
  if (int(inliers.size()) < 2 * options.min_cross_inliers ||
      double(inliers.size()) < options.band_peak_ratio * runner_up)
    return Eigen::Matrix3d::Identity();
  *agreeing_votes = int(inliers.size());
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (int i : inliers) m += observed_rays[i] * predicted_rays[i].transpose();
  return closest_rotation(m);  // observed direction ~ correction * predicted direction
}

BandPairResult match_band_pair(const Relation& relation, const Rigid3d& b_from_a, const BandCrop& crop_a,
                               const BandCrop& crop_b, const ScanIndex& scan, const FrontendOptions& options) {
  BandPairResult result;
  result.a_from_b = b_from_a.inverse();
  const PatchShape shape = patch_shape(relation, options);
  const auto& in_a = scan.rig.sensors[relation.sensor_a].intrinsics;
  const auto& in_b = scan.rig.sensors[relation.sensor_b].intrinsics;
  const int r = options.band_refine_px;
  const int cell_size = 2 * (relation.along_x ? shape.half_x : shape.half_y) + 1;
  std::vector<char> cell_used((relation.along_x ? in_a.width : in_a.height) / cell_size + 1, 0);
  struct Aligned {
    Anchor anchor;
    double dx, dy;
  };
  std::vector<Aligned> aligned;
  Anchor anchor;
  PatchSampler sampler;
  CorrelationSums sums;
  std::vector<double> surface;
  for (std::size_t k = 0; k < crop_a.patches.size(); ++k) {
    const Pixel& corner = crop_a.patches[k].pixel;
    const int cell = (relation.along_x ? corner.x : corner.y) / cell_size;
    if (cell_used[cell]) continue;
    set_anchor(crop_a, k, &anchor);
    if (!warp_anchor(relation, b_from_a, scan, crop_b, shape, r, &anchor)) continue;
    prepare_sampler(anchor, crop_b.gray, &sampler);
    // Every shift of the window that keeps the patch inside b; the peak's four neighbours must be
    // scored too (for the sub-pixel fit), so a peak on the rim of b or of the window is refused.
    const int side = 2 * r + 1;
    const int best = correlation_surface(anchor, sampler, crop_b.gray, r, &surface, &sums);
    if (best < 0) continue;
    ++result.anchors;
    const int bx = best % side, by = best / side;
    if (surface[best] < options.band_min_ncc || !is_distinct_peak(surface, side, best, options.band_peak_margin))
      continue;
    cell_used[cell] = 1;  // one aligned patch per cell: matches spread along the band
    ++result.aligned;
    const double dx = bx - r + parabola_peak(surface[best - 1], surface[best], surface[best + 1]);
    const double dy = by - r + parabola_peak(surface[best - side], surface[best], surface[best + side]);
    aligned.push_back({anchor, dx, dy});
  }
  if (int(aligned.size()) < options.min_cross_inliers) return result;
  // One shift for the pair up to the spread of the rotation error along the band: the median.
  std::vector<double> xs, ys;
  for (const Aligned& a : aligned) xs.push_back(a.dx), ys.push_back(a.dy);
  std::nth_element(xs.begin(), xs.begin() + xs.size() / 2, xs.end());
  std::nth_element(ys.begin(), ys.begin() + ys.size() / 2, ys.end());
  const double median_x = xs[xs.size() / 2], median_y = ys[ys.size() / 2];
  std::vector<Eigen::Vector3d> rays_a, points_b;
  for (const Aligned& a : aligned) {
    if (std::hypot(a.dx - median_x, a.dy - median_y) > options.band_max_shift_spread_px) continue;
    const double x = a.anchor.centre_in_b.x + a.dx, y = a.anchor.centre_in_b.y + a.dy;
    const int ix = int(std::lround(x)) - crop_b.roi.x, iy = int(std::lround(y)) - crop_b.roi.y;
    if (ix < 0 || iy < 0 || ix >= crop_b.depth.width || iy >= crop_b.depth.height) continue;
    const float z_b = crop_b.depth.at(ix, iy);
    if (!(z_b >= options.min_depth_m && z_b <= options.max_depth_m)) continue;
    // The depth b measures there must be the point's (an occluding edge or a wrong peak is not).
    const double sigma_a = options.depth_noise_coefficient * a.anchor.depth * a.anchor.depth;
    const double sigma_b = options.depth_noise_coefficient * double(z_b) * z_b;
    if (std::abs(z_b - a.anchor.predicted_depth_in_b) > 3.0 * std::hypot(sigma_a, sigma_b) + options.band_depth_slack_m)
      continue;
    BandMatch m;
    m.in_a = {float(a.anchor.pixel.x), float(a.anchor.pixel.y), a.anchor.depth, 0};
    m.in_b = {float(x), float(y), z_b, 0};
    result.matches.push_back(m);
    rays_a.push_back(ray(in_a, a.anchor.pixel.x, a.anchor.pixel.y));
    points_b.push_back(in_b.backproject(x, y, z_b));
  }
  if (int(result.matches.size()) < options.min_cross_inliers) {
    result.matches.clear();
    return result;
  }
  // The pair's rotation fitted to the matched directions as seen from a's centre: ray_a ~
  // correction * (a_from_b_predicted * point_b) normalised. (The cameras are centimetres apart, so
  // b's own rays differ from a's by the parallax, 1.4 deg for 6 cm at 2.5 m; b's depth noise moves
  // the direction from a by baseline * sigma_z / z^2, some 0.003 deg.)
  const Rigid3d predicted = result.a_from_b;
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < rays_a.size(); ++k) m += rays_a[k] * (predicted * points_b[k]).normalized().transpose();
  bool degenerate = false;
  const Eigen::Matrix3d correction = closest_rotation(m, &degenerate);
  if (degenerate || rad2deg(rotation_angle(correction)) > options.cross_max_deviation_deg) {
    result.matches.clear();
    return result;
  }
  result.a_from_b = make_rigid(correction, Eigen::Vector3d::Zero()) * predicted;
  return result;
}

}  // namespace panoscan::cross_camera
