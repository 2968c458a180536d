// Surfel baseline with ElasticFusion's update rule (see surfel_baseline.h).
#include "panoscan/core/timer.h"
#include "panoscan/recon/surfel_baseline.h"

#include <chrono>
#include <cmath>
#include <unordered_map>

#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"

namespace panoscan {
namespace {

struct Surfel {
  Eigen::Vector3f position;
  Eigen::Vector3f normal;
  Eigen::Vector3f colour;  // 0..255
  float radius = 0.f;
  float confidence = 0.f;
};

}  // namespace

void SurfelOptions::check(const std::string& origin) const {
  if (!(max_depth_m > 0)) throw make_error(origin, "surfels.max_depth_m", "must be > 0");
  if (!(merge_distance_m > 0)) throw make_error(origin, "surfels.merge_distance_m", "must be > 0");
  if (!(merge_angle_deg > 0 && merge_angle_deg <= 180))
    throw make_error(origin, "surfels.merge_angle_deg", "must be in (0, 180]");
  if (!(min_confidence >= 0)) throw make_error(origin, "surfels.min_confidence", "must be >= 0");
  if (direction_bins_height < 4) throw make_error(origin, "surfels.direction_bins_height", "must be >= 4");
  if (frame_stride < 1) throw make_error(origin, "surfels.frame_stride", "must be >= 1");
}

SurfelResult build_surfel_baseline(const ScanIndex& scan, const RigTrajectory& trajectory,
                                   const SurfelOptions& options) {
  options.check();
  check_rig_trajectory(trajectory, scan, "poses");
  const auto t0 = std::chrono::steady_clock::now();
  Equirectangular bins;
  bins.height = options.direction_bins_height;
  const Rigid3d pano_from_world = trajectory.world_from_axis.inverse();
  const double cos_merge = std::cos(options.merge_angle_deg * M_PI / 180.0);
  std::vector<Surfel> surfels;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> bin_surfels;  // direction bin -> surfels
  for (std::size_t s = 0; s < scan.frames.size(); ++s) {
    const PinholeIntrinsics& k = scan.rig.sensors[s].intrinsics;
    const double half_diagonal = 0.5 * std::hypot(double(k.width), double(k.height));
    for (std::size_t f = 0; f < scan.frames[s].size(); f += std::size_t(options.frame_stride)) {
      const RgbdFrame frame = load_frame(scan, int(s), f);
      const Rigid3d& world_from_cam = trajectory.world_from_cam[s][f].world_from_cam;
      const int w = frame.depth.width, h = frame.depth.height;
      auto valid = [&](int x, int y) {
        const float z = frame.depth.at(x, y);
        return z > 0.f && std::isfinite(z) && z <= options.max_depth_m;
      };
      // Measurements of this frame (computed in parallel), then merged serially in pixel order.
      struct Measurement {
        bool ok = false;
        Eigen::Vector3d point, normal;
        double radius = 0, confidence = 0;
      };
      std::vector<Measurement> meas(std::size_t(w) * h);
      tbb::parallel_for(1, h - 1, [&](int y) {
        for (int x = 1; x + 1 < w; ++x) {
          if (!valid(x, y) || !valid(x + 1, y) || !valid(x, y + 1)) continue;
          const Eigen::Vector3d p = k.backproject(x, y, frame.depth.at(x, y));
          const Eigen::Vector3d px = k.backproject(x + 1, y, frame.depth.at(x + 1, y));
          const Eigen::Vector3d py = k.backproject(x, y + 1, frame.depth.at(x, y + 1));
          Eigen::Vector3d n = (px - p).cross(py - p);
          if (!(n.norm() > 0)) continue;
          n.normalize();
          if (n.dot(p) > 0) n = -n;  // facing the camera
          const double nz = std::abs(n.dot(p.normalized()));
          if (nz < 0.1) continue;  // grazing
          Measurement& m = meas[std::size_t(y) * w + x];
          m.ok = true;
          m.point = world_from_cam * p;
          m.normal = world_from_cam.linear() * n;
          m.radius = std::sqrt(2.0) * p.z() / (k.fx * nz);
          const double g = std::hypot(x - k.cx, y - k.cy) / half_diagonal;
          m.confidence = std::exp(-g * g / (2 * 0.6 * 0.6));
        }
      });
      for (int y = 1; y + 1 < h; ++y) {
        for (int x = 1; x + 1 < w; ++x) {
          const Measurement& m = meas[std::size_t(y) * w + x];
          if (!m.ok) continue;
          const Eigen::Vector3d in_pano = pano_from_world * m.point;
          const Eigen::Vector2d pixel = bins.pixel(in_pano);
          const int bu = std::clamp(int(std::lround(pixel.x())), 0, bins.width() - 1);
          const int bv = std::clamp(int(std::lround(pixel.y())), 0, bins.height - 1);
          const std::uint32_t key = std::uint32_t(bv) * std::uint32_t(bins.width()) + std::uint32_t(bu);
          const double range = in_pano.norm();
          std::vector<std::uint32_t>& list = bin_surfels[key];
          int best = -1;
          double best_distance = options.merge_distance_m;
          for (const std::uint32_t idx : list) {
            const Surfel& sf = surfels[idx];
            const double distance = std::abs((pano_from_world * sf.position.cast<double>()).norm() - range);
            if (distance < best_distance && sf.normal.cast<double>().dot(m.normal) > cos_merge) {
              best_distance = distance;
              best = int(idx);
            }
          }
          const Eigen::Vector3f colour(frame.rgb.at(x, y, 0), frame.rgb.at(x, y, 1), frame.rgb.at(x, y, 2));
          if (best >= 0) {
            Surfel& sf = surfels[std::size_t(best)];
            const float a = float(m.confidence), c = sf.confidence;
            sf.position = (c * sf.position + a * m.point.cast<float>()) / (c + a);
            sf.normal = ((c * sf.normal + a * m.normal.cast<float>()) / (c + a)).normalized();
            sf.colour = (c * sf.colour + a * colour) / (c + a);
            sf.radius = std::min(sf.radius, float(m.radius));
            sf.confidence = c + a;
          } else {
            Surfel sf;
            sf.position = m.point.cast<float>();
            sf.normal = m.normal.cast<float>();
            sf.colour = colour;
            sf.radius = float(m.radius);
            sf.confidence = float(m.confidence);
            list.push_back(std::uint32_t(surfels.size()));
            surfels.push_back(sf);
          }
        }
      }
    }
  }
  SurfelResult result;
  result.memory_bytes = surfels.capacity() * sizeof(Surfel) + bin_surfels.size() * (sizeof(std::uint32_t) * 2 + 48);
  for (const Surfel& sf : surfels) {
    if (sf.confidence < options.min_confidence) continue;
    result.surfels.positions.push_back(sf.position.cast<double>());
    result.surfels.normals.push_back(sf.normal);
    result.surfels.colours.push_back({std::uint8_t(std::lround(sf.colour.x())),
                                      std::uint8_t(std::lround(sf.colour.y())),
                                      std::uint8_t(std::lround(sf.colour.z()))});
    result.radii.push_back(sf.radius);
    result.confidences.push_back(sf.confidence);
  }
  result.seconds = seconds_since(t0);
  return result;
}

ImageF32 raycast_surfels(const SurfelResult& result, const Rigid3d& world_from_pano, const Equirectangular& pano) {
  const int width = pano.width(), height = pano.height;
  ImageF32 depth(width, height, 1, 0.f);
  const Rigid3d pano_from_world = world_from_pano.inverse();
  // Splat each disk over the panorama pixels its angular radius covers; per pixel keep the nearest
  // ray-disk intersection. Serial: the min-reduction per pixel would otherwise need atomics.
  const double pixel_angle = M_PI / height;
  for (std::size_t i = 0; i < result.surfels.size(); ++i) {
    const Eigen::Vector3d c = pano_from_world * result.surfels.positions[i];
    const Eigen::Vector3d n = pano_from_world.linear() * result.surfels.normals[i].cast<double>();
    const double r = result.radii[i];
    const double range = c.norm();
    if (!(range > r)) continue;
    const Eigen::Vector2d centre = pano.pixel(c);
    const double angular = std::asin(std::min(1.0, r / range));
    const double sin_theta = std::max(0.05, std::sqrt(c.x() * c.x() + c.y() * c.y()) / range);
    const int dv = int(std::ceil(angular / pixel_angle)) + 1;
    const int du = std::min(width / 2, int(std::ceil(angular / pixel_angle / sin_theta)) + 1);
    const int cu = int(std::lround(centre.x())), cv = int(std::lround(centre.y()));
    for (int v = std::max(0, cv - dv); v <= std::min(height - 1, cv + dv); ++v) {
      for (int u0 = cu - du; u0 <= cu + du; ++u0) {
        const int u = ((u0 % width) + width) % width;
        const Eigen::Vector3d ray = pano.direction(u, v);
        const double denom = n.dot(ray);
        if (std::abs(denom) < 1e-6) continue;
        const double t = n.dot(c) / denom;
        if (!(t > 0)) continue;
        if ((t * ray - c).squaredNorm() > r * r) continue;
        float& d = depth.at(u, v);
        if (d == 0.f || t < d) d = float(t);
      }
    }
  }
  return depth;
}

}  // namespace panoscan
