// Pre-stitched baselines of Table 1: grouping, the virtual camera, z-buffered rasterisation,
// Open3D's RGB-D odometry over the stitched sequence and the TSDF fusion.
#include "panoscan/core/timer.h"
#include "panoscan/recon/prestitched.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/recon/open3d_calls.h"

namespace panoscan {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void StitchOptions::check(const std::string& origin) const {
  if (width < 0) throw make_error(origin, "stitch.width", "must be >= 0 (0 = the reference camera's width)");
  if (height < 0) throw make_error(origin, "stitch.height", "must be >= 0 (0 = twice the width)");
  if (width > 0 && width < 16) throw make_error(origin, "stitch.width", "must be at least 16 pixels");
  if (height > 0 && height < 16) throw make_error(origin, "stitch.height", "must be at least 16 pixels");
  if (!(max_time_gap_s >= 0) || !std::isfinite(max_time_gap_s))
    throw make_error(origin, "stitch.max_time_gap_s", "must be a finite number >= 0 (0 = automatic)");
  if (!(max_edge_depth_ratio > 1) || !std::isfinite(max_edge_depth_ratio))
    throw make_error(origin, "stitch.max_edge_depth_ratio", "must be a finite number > 1");
  if (threads < 0) throw make_error(origin, "threads", "must be >= 0");
}

void StitchedOdometryOptions::check(const std::string& origin) const {
  if (iterations_per_level.empty())
    throw make_error(origin, "odometry.iterations_per_level", "needs at least one level");
  for (int n : iterations_per_level)
    if (n < 1) throw make_error(origin, "odometry.iterations_per_level", "every level needs >= 1 iteration");
  if (!(max_depth_difference_m > 0)) throw make_error(origin, "odometry.max_depth_difference_m", "must be > 0");
  if (!(min_depth_m >= 0)) throw make_error(origin, "odometry.min_depth_m", "must be >= 0");
  if (!(max_depth_m > min_depth_m)) throw make_error(origin, "odometry.max_depth_m", "must exceed min_depth_m");
}

namespace {

void check_reference_sensor(const RigInfo& rig, const std::string& origin) {
  if (rig.sensors.empty()) throw make_error(origin, "sensors", "the rig has no sensors");
  if (rig.reference_sensor < 0 || rig.reference_sensor >= int(rig.sensors.size()))
    throw make_error(origin, "reference_sensor", "out of range");
}

int stitched_width(const RigInfo& rig, const StitchOptions& options) {
  return options.width > 0 ? options.width : rig.sensors[std::size_t(rig.reference_sensor)].intrinsics.width;
}

}  // namespace

PinholeIntrinsics stitched_intrinsics(const RigInfo& rig, const StitchOptions& options) {
  options.check();
  check_reference_sensor(rig, "rig");
  const PinholeIntrinsics& ref = rig.sensors[std::size_t(rig.reference_sensor)].intrinsics;
  PinholeIntrinsics k;
  k.width = stitched_width(rig, options);
  k.height = options.height > 0 ? options.height : 2 * k.width;
  k.fx = ref.fx * double(k.width) / double(ref.width);
  k.cx = (k.width - 1) / 2.0;
  k.cy = (k.height - 1) / 2.0;
  // The largest vertical tangent of any camera's border ray in the reference camera (rotation of
  // the calibrated extrinsics only: the cameras are centimetres apart, the walls metres away).
  double max_tan = 0.0;
  for (const SensorInfo& sensor : rig.sensors) {
    const PinholeIntrinsics& s = sensor.intrinsics;
    const Eigen::Matrix3d r = sensor.ref_from_cam.rotation();
    auto consider = [&](double u, double v) {
      const Eigen::Vector3d d = r * s.backproject(u, v, 1.0);
      // Rays more than ~84 deg off the reference optical axis cannot be held by any pinhole row.
      if (d.z() > 0.1 * d.norm()) max_tan = std::max(max_tan, std::abs(d.y() / d.z()));
    };
    for (int u = 0; u < s.width; ++u) {
      consider(u, -0.5);
      consider(u, s.height - 0.5);
    }
    for (int v = 0; v < s.height; ++v) {
      consider(-0.5, v);
      consider(s.width - 0.5, v);
    }
  }
  if (!(max_tan > 0)) throw make_error("rig", "ref_from_cam", "no camera looks along the reference camera's view");
  k.fy = ((k.height - 1) / 2.0) / max_tan;
  return k;
}

std::vector<FrameGroup> group_frames_by_time(const ScanIndex& scan, const StitchOptions& options) {
  options.check();
  const std::string origin = scan.root.string();
  check_reference_sensor(scan.rig, origin);
  if (scan.frames.size() != scan.rig.sensors.size())
    throw make_error(origin, "frames", "the frame listings do not match the rig's sensors");
  for (std::size_t c = 0; c < scan.frames.size(); ++c)
    if (scan.frames[c].empty())
      throw make_error(origin, scan.rig.sensors[c].name, "the camera has no frames to stitch");
  const std::size_t r = std::size_t(scan.rig.reference_sensor);
  const auto& reference = scan.frames[r];
  if (reference.size() < 2)
    throw make_error(origin, scan.rig.sensors[r].name, "the reference camera needs at least two frames to track");
  double gap = options.max_time_gap_s;
  if (gap == 0.0) {
    std::vector<double> intervals;
    for (std::size_t i = 1; i < reference.size(); ++i)
      intervals.push_back(reference[i].timestamp - reference[i - 1].timestamp);
    std::nth_element(intervals.begin(), intervals.begin() + std::ptrdiff_t(intervals.size() / 2), intervals.end());
    gap = 0.5 * intervals[intervals.size() / 2];
  }
  std::vector<FrameGroup> groups;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    FrameGroup g;
    g.timestamp = reference[i].timestamp;
    g.reference_frame = i;
    g.frame_of_sensor.assign(scan.frames.size(), -1);
    for (std::size_t c = 0; c < scan.frames.size(); ++c) {
      if (c == r) {
        g.frame_of_sensor[c] = int(i);
        continue;
      }
      const auto& frames = scan.frames[c];
      const auto after = std::lower_bound(frames.begin(), frames.end(), g.timestamp,
                                          [](const FrameEntry& e, double t) { return e.timestamp < t; });
      std::ptrdiff_t best = -1;
      double best_gap = std::numeric_limits<double>::infinity();
      for (auto it : {after - 1, after}) {
        if (it < frames.begin() || it >= frames.end()) continue;
        const double d = std::abs(it->timestamp - g.timestamp);
        if (d < best_gap) {  // strict: the earlier frame wins a tie
          best_gap = d;
          best = it - frames.begin();
        }
      }
      if (best >= 0 && best_gap <= gap) g.frame_of_sensor[c] = int(best);
    }
    groups.push_back(std::move(g));
  }
  return groups;
}

std::vector<Rigid3d> virtual_from_cameras(const ScanIndex& scan, const FrameGroup& group, const RigTrajectory* poses) {
  const std::size_t n = scan.rig.sensors.size();
  const std::size_t r = std::size_t(scan.rig.reference_sensor);
  std::vector<Rigid3d> out(n, Rigid3d::Identity());
  if (!poses) {
    // "EX": the calibrated extrinsics, as if every camera had fired with the reference camera.
    for (std::size_t c = 0; c < n; ++c) out[c] = scan.rig.sensors[c].ref_from_cam;
    return out;
  }
  // "GT": each frame's own pose (at its own timestamp) relative to the reference frame.
  const Rigid3d ref_from_world = poses->world_from_cam[r][group.reference_frame].world_from_cam.inverse();
  for (std::size_t c = 0; c < n; ++c) {
    const int f = group.frame_of_sensor[c];
    if (f >= 0) out[c] = ref_from_world * poses->world_from_cam[c][std::size_t(f)].world_from_cam;
  }
  return out;
}

namespace {

struct ProjectedVertex {
  double u = 0, v = 0;  // virtual pixel
  double inv_z = 0;     // 1 / depth in the virtual camera
  double source_z = 0;  // depth in the source camera
  float rgb[3] = {0, 0, 0};
  bool valid = false;
};

// Draws triangle (a, b, c) into the z-buffered stitched frame. Pixel centres inside (edge
// functions >= 0, with both orientations) are filled; 1/z is affine in the image for a planar
// triangle, so interpolating it barycentrically is exact; colour is interpolated perspective-correctly.
void rasterise(const ProjectedVertex& a, const ProjectedVertex& b, const ProjectedVertex& c, StitchedFrame& out) {
  const double area = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
  if (std::abs(area) < 1e-12) return;
  const int w = out.depth.width, h = out.depth.height;
  const int u0 = std::max(0, int(std::ceil(std::min({a.u, b.u, c.u}))));
  const int u1 = std::min(w - 1, int(std::floor(std::max({a.u, b.u, c.u}))));
  const int v0 = std::max(0, int(std::ceil(std::min({a.v, b.v, c.v}))));
  const int v1 = std::min(h - 1, int(std::floor(std::max({a.v, b.v, c.v}))));
  if (u0 > u1 || v0 > v1) return;
  const double inv_area = 1.0 / area;
  constexpr double kEdgeTolerance = -1e-9;  // shared edges are drawn by both triangles (no cracks)
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u) {
      const double wa = ((b.u - u) * (c.v - v) - (b.v - v) * (c.u - u)) * inv_area;
      const double wb = ((c.u - u) * (a.v - v) - (c.v - v) * (a.u - u)) * inv_area;
      const double wc = 1.0 - wa - wb;
      if (wa < kEdgeTolerance || wb < kEdgeTolerance || wc < kEdgeTolerance) continue;
      const double inv_z = wa * a.inv_z + wb * b.inv_z + wc * c.inv_z;
      if (!(inv_z > 0)) continue;
      const float z = float(1.0 / inv_z);
      float& zbuf = out.depth.at(u, v);
      if (zbuf > 0 && zbuf <= z) continue;
      zbuf = z;
      for (int k = 0; k < 3; ++k) {
        const double value = (wa * a.inv_z * a.rgb[k] + wb * b.inv_z * b.rgb[k] + wc * c.inv_z * c.rgb[k]) / inv_z;
        out.rgb.at(u, v, k) = std::uint8_t(std::clamp(std::lround(value), 0L, 255L));
      }
    }
}

void draw_frame(const RgbdFrame& frame, const PinholeIntrinsics& source, const Rigid3d& virtual_from_cam,
                const PinholeIntrinsics& stitched, double max_ratio, StitchedFrame& out) {
  const int w = frame.depth.width, h = frame.depth.height;
  std::vector<ProjectedVertex> vertices(std::size_t(w) * h);
  constexpr double kNearM = 0.05;  // points this close to (or behind) the virtual camera are not drawn
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z = frame.depth.at(x, y);
      if (!(std::isfinite(z) && z > 0.f)) continue;
      const Eigen::Vector3d p = virtual_from_cam * source.backproject(x, y, z);
      if (p.z() < kNearM) continue;
      ProjectedVertex& vert = vertices[std::size_t(y) * w + x];
      const Eigen::Vector2d px = stitched.project(p);
      vert.u = px.x();
      vert.v = px.y();
      vert.inv_z = 1.0 / p.z();
      vert.source_z = z;
      for (int k = 0; k < 3; ++k) vert.rgb[k] = frame.rgb.at(x, y, k);
      vert.valid = true;
    }
  auto connected = [&](const ProjectedVertex& a, const ProjectedVertex& b, const ProjectedVertex& c) {
    if (!(a.valid && b.valid && c.valid)) return false;
    const double lo = std::min({a.source_z, b.source_z, c.source_z});
    const double hi = std::max({a.source_z, b.source_z, c.source_z});
    return hi <= lo * max_ratio;
  };
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const ProjectedVertex& p00 = vertices[std::size_t(y) * w + x];
      const ProjectedVertex& p10 = vertices[std::size_t(y) * w + x + 1];
      const ProjectedVertex& p01 = vertices[std::size_t(y + 1) * w + x];
      const ProjectedVertex& p11 = vertices[std::size_t(y + 1) * w + x + 1];
      if (connected(p00, p10, p01)) rasterise(p00, p10, p01, out);
      if (connected(p10, p11, p01)) rasterise(p10, p11, p01, out);
    }
}

}  // namespace

StitchedFrame stitch_group(const ScanIndex& scan, const FrameGroup& group, const std::vector<Rigid3d>& virtual_from_cam,
                           const PinholeIntrinsics& stitched, const StitchOptions& options) {
  options.check();
  const std::string origin = scan.root.string();
  if (group.frame_of_sensor.size() != scan.rig.sensors.size() || virtual_from_cam.size() != scan.rig.sensors.size())
    throw make_error(origin, "frame group", "expected one entry per sensor");
  if (stitched.width < 1 || stitched.height < 1 || !(stitched.fx > 0) || !(stitched.fy > 0))
    throw make_error(origin, "stitched intrinsics", "invalid image size or focal length");
  StitchedFrame out;
  out.timestamp = group.timestamp;
  out.rgb = ImageU8(stitched.width, stitched.height, 3, 0);
  out.depth = ImageF32(stitched.width, stitched.height, 1, 0.f);
  for (std::size_t c = 0; c < scan.rig.sensors.size(); ++c) {
    const int f = group.frame_of_sensor[c];
    if (f < 0) continue;
    if (std::size_t(f) >= scan.frames[c].size())
      throw make_error(origin, scan.rig.sensors[c].name, "frame index " + std::to_string(f) + " out of range");
    if (!virtual_from_cam[c].matrix().allFinite())
      throw make_error(origin, scan.rig.sensors[c].name, "non-finite pose for stitching");
    const RgbdFrame frame = load_frame(scan, int(c), std::size_t(f));
    draw_frame(frame, scan.rig.sensors[c].intrinsics, virtual_from_cam[c], stitched, options.max_edge_depth_ratio, out);
  }
  return out;
}

StitchedScanInfo write_stitched_scan(const ScanIndex& scan, const fs::path& out_dir, const StitchOptions& options,
                                     const RigTrajectory* poses, bool overwrite) {
  const auto t0 = Clock::now();
  options.check();
  if (poses) check_rig_trajectory(*poses, scan, "stitching poses");
  const std::vector<FrameGroup> groups = group_frames_by_time(scan, options);
  StitchedScanInfo info;
  info.dir = out_dir;
  info.intrinsics = stitched_intrinsics(scan.rig, options);
  info.frames = groups.size();
  for (const auto& g : groups)
    for (int f : g.frame_of_sensor) info.missing_camera_frames += f < 0 ? 1 : 0;

  const SensorInfo& reference = scan.rig.sensors[std::size_t(scan.rig.reference_sensor)];
  RigInfo rig;
  SensorInfo sensor;
  sensor.name = "stitched";
  sensor.intrinsics = info.intrinsics;
  sensor.depth_scale = reference.depth_scale;
  sensor.nominal_fps = reference.nominal_fps;
  rig.sensors.push_back(sensor);
  rig.reference_sensor = 0;
  rig.description = std::string("pre-stitched (") +
                    (poses ? "relative poses: " + poses->source : "calibrated extrinsics") + ") from " +
                    scan.root.string();
  ScanWriter writer(out_dir, rig, overwrite);
  // Frames are rendered in parallel in batches and written in timestamp order (the writer's rule).
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  const std::size_t batch = 16;
  for (std::size_t start = 0; start < groups.size(); start += batch) {
    const std::size_t end = std::min(groups.size(), start + batch);
    std::vector<StitchedFrame> frames(end - start);
    arena.execute([&] {
      tbb::parallel_for(start, end, [&](std::size_t i) {
        frames[i - start] =
            stitch_group(scan, groups[i], virtual_from_cameras(scan, groups[i], poses), info.intrinsics, options);
      });
    });
    for (const StitchedFrame& f : frames)
      writer.write_frame(0, f.timestamp, f.rgb, depth_to_png_units(f.depth, sensor.depth_scale));
  }
  writer.commit();
  info.seconds = seconds_since(t0);
  return info;
}

namespace {

// Runs Open3D's OpenMP regions on one thread for the guard's lifetime. Open3D 0.16 sizes every
// parallel region with num_threads(EstimateMaxThreads()), which reads OMP_NUM_THREADS on each call
// (omp_set_num_threads does not reach it). One thread makes the odometry reproducible (Open3D
// merges per-thread sums in arrival order) and, on a loaded machine, faster (measured 8.7 s against
// 16.5 s with passive and 122 s with spinning OpenMP waits for 123 steps at 160x320). Not
// thread-safe against concurrent getenv/setenv elsewhere in the process.
class SingleThreadedOpen3d {
 public:
  SingleThreadedOpen3d() {
    if (const char* value = std::getenv("OMP_NUM_THREADS")) {
      had_value_ = true;
      previous_ = value;
    }
    ::setenv("OMP_NUM_THREADS", "1", 1);
  }
  ~SingleThreadedOpen3d() {
    if (had_value_) {
      ::setenv("OMP_NUM_THREADS", previous_.c_str(), 1);
    } else {
      ::unsetenv("OMP_NUM_THREADS");
    }
  }
  SingleThreadedOpen3d(const SingleThreadedOpen3d&) = delete;
  SingleThreadedOpen3d& operator=(const SingleThreadedOpen3d&) = delete;

 private:
  bool had_value_ = false;
  std::string previous_;
};

}  // namespace

StitchedOdometryResult track_stitched_scan(const ScanIndex& stitched, const StitchedOdometryOptions& options) {
  options.check();
  open3d_calls::load();  // before the clock: loading Open3D is not the odometry's time
  const auto t0 = Clock::now();
  const std::string origin = stitched.root.string();
  if (stitched.rig.sensors.empty() || stitched.frames.empty() || stitched.frames[0].empty())
    throw make_error(origin, "frames", "no frames to track");
  const PinholeIntrinsics& k = stitched.rig.sensors[0].intrinsics;

  SingleThreadedOpen3d single_thread;
  StitchedOdometryResult result;
  result.trajectory.source = "open3d-rgbd-odometry";
  result.trajectory.ref_from_cam = {Rigid3d::Identity()};
  result.trajectory.world_from_cam.resize(1);
  auto& poses = result.trajectory.world_from_cam[0];
  const auto& frames = stitched.frames[0];
  poses.push_back({frames[0].timestamp, Rigid3d::Identity()});
  // Open3D's warnings are silenced inside (a failed step is counted instead).
  open3d_calls::RgbdImage previous(load_frame(stitched, 0, 0), options.max_depth_m, true);
  Eigen::Matrix4d last_step = Eigen::Matrix4d::Identity();  // previous_from_current of the last step
  for (std::size_t i = 1; i < frames.size(); ++i) {
    open3d_calls::RgbdImage current(load_frame(stitched, 0, i), options.max_depth_m, true);
    const open3d_calls::OdometryStep odometry =
        open3d_calls::rgbd_odometry(current, previous, k, last_step, options.iterations_per_level,
                                    options.max_depth_difference_m, options.min_depth_m, options.max_depth_m);
    const bool ok = odometry.converged;
    const Eigen::Matrix4d& step = odometry.previous_from_current;
    Eigen::Matrix4d used = last_step;
    if (ok && step.allFinite()) {
      used = step;
    } else {
      ++result.failed_steps;
    }
    Rigid3d previous_from_current;
    previous_from_current.matrix() = used;
    poses.push_back({frames[i].timestamp, poses.back().world_from_cam * previous_from_current});
    last_step = used;
    previous = std::move(current);
  }
  result.seconds = seconds_since(t0);
  return result;
}

PrestitchedResult run_prestitched_baseline(const ScanIndex& scan, const fs::path& work_dir,
                                           const PrestitchedOptions& options, const RigTrajectory* poses) {
  options.tsdf.check();
  options.odometry.check();
  PrestitchedResult result;
  result.stitched = write_stitched_scan(scan, work_dir, options.stitch, poses, true);
  const ScanIndex stitched = read_scan_index(work_dir);
  result.odometry = track_stitched_scan(stitched, options.odometry);
  result.tsdf = build_tsdf_baseline(stitched, result.odometry.trajectory, options.tsdf);
  return result;
}

}  // namespace panoscan
