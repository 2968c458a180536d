#include "panoscan/sim/simulator.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include <embree3/rtcore_config.h>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include "panoscan/core/pose_json.h"
#include "panoscan/core/cpu_features.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/version.h"
#include "panoscan/core/random.h"
#include "panoscan/core/image_io.h"
#include "panoscan/sim/noise.h"

namespace panoscan {

namespace {

nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

ScanPosition checked_position(const Scene& scene, int position_index) {
  if (scene.positions.empty())
    throw make_error("<scene " + scene.name + ">", "positions", "the scene has no scanning positions");
  if (position_index < 0 || position_index >= int(scene.positions.size()))
    throw make_error("<scene " + scene.name + ">", "position",
                     "index " + std::to_string(position_index + 1) + " does not exist (the scene has " +
                         std::to_string(scene.positions.size()) + " positions)");
  return scene.positions[position_index];
}

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Adds the thread time of its scope to `sink` (nothing when null).
class ScopedClock {
 public:
  explicit ScopedClock(std::atomic<std::int64_t>* sink) : sink_(sink), start_(sink ? now_ns() : 0) {}
  ~ScopedClock() {
    if (sink_) *sink_ += now_ns() - start_;
  }
  ScopedClock(const ScopedClock&) = delete;
  ScopedClock& operator=(const ScopedClock&) = delete;

 private:
  std::atomic<std::int64_t>* sink_;
  std::int64_t start_;
};

double seconds_of(const std::atomic<std::int64_t>& ns) { return double(ns.load()) * 1e-9; }

}  // namespace

struct Simulator::StageClocks {
  RenderTimes render;
  std::atomic<std::int64_t> depth_noise{0}, colour{0}, encode{0}, ground_truth{0}, write{0};
};

std::string SimStageTimes::summary() const {
  const std::pair<const char*, double> stages[] = {
      {"rays", rays_s},     {"shading", shading_s}, {"depth noise", depth_noise_s},
      {"colour", colour_s}, {"encode", encode_s},   {"ground truth", ground_truth_s},
      {"write", write_s}};
  double sum = 0;
  for (const auto& stage : stages) sum += stage.second;
  std::string text = fmt::format("{} frames in {:.1f} s ({:.1f} Mpixel/s); per frame, thread seconds:", frames, wall_s,
                                 wall_s > 0 ? double(pixels) / wall_s * 1e-6 : 0.0);
  for (const auto& [name, seconds] : stages)
    text += fmt::format(" {} {:.1f} ({:.0f}%),", name, seconds, sum > 0 ? 100.0 * seconds / sum : 0.0);
  text += fmt::format(" other {:.1f}; once, wall seconds: probe {:.1f}, finish {:.1f}", frame_threads_s - sum, probe_s,
                      finish_s);
  return text;
}

Simulator::Simulator(const Scene& scene, int position_index, const SimOptions& options)
    : scene_(scene),
      position_(checked_position(scene, position_index)),
      options_((options.check(), options)),
      rig_(make_rig(options.rig, options.seed)),
      motion_(options.motion, position_, options.seed),
      renderer_(scene) {
  schedule_ = make_frame_schedule(options_.shutter, options_.output, int(rig_.num_sensors()), motion_.duration(),
                                  options_.seed);
}

Rigid3d Simulator::world_from_bracket(double t) const {
  return motion_.world_from_axis(t) * rig_.axis_from_bracket * motion_.wobble(t);
}

Rigid3d Simulator::world_from_cam(int sensor, double timestamp) const {
  return world_from_bracket(timestamp - options_.shutter.start_time_s) * rig_.bracket_from_cam[sensor];
}

RigInfo Simulator::rig_info() const {
  RigInfo info;
  info.reference_sensor = rig_.reference_sensor;
  info.description = "simulated by panoscan: scene " + scene_.name + ", position " + position_.name;
  info.motion = options_.motion.kind == MotionKind::kHandheld ? RigMotion::kHandheld : RigMotion::kRotator;
  for (std::size_t c = 0; c < rig_.num_sensors(); ++c) {
    SensorInfo sensor;
    sensor.name = "cam" + std::to_string(c);
    sensor.intrinsics = rig_.intrinsics;
    sensor.depth_scale = 5000.0;
    sensor.nominal_fps = options_.shutter.fps;
    sensor.ref_from_cam = rig_.ref_from_cam_calibrated[c];
    info.sensors.push_back(sensor);
  }
  return info;
}

std::string Simulator::rig_truth_json() const {
  nlohmann::json j;
  j["format"] = "panoscan-rig-truth";
  j["version"] = 1;
  // Which code rendered the scan: a scan cache outlives the code, so a record made from cached scans
  // can say whether the simulator has changed since (see panoscan tables).
  // The ray tracer's kernels too: Embree's differ by instruction set at a few silhouette pixels.
  j["rendered_by"] = {{"version", project_version()},
                      {"source_revision", source_revision()},
                      {"ray_tracer", fmt::format("Embree {}.{}.{}, {} kernels", RTC_VERSION_MAJOR, RTC_VERSION_MINOR,
                                                 RTC_VERSION_PATCH, cpu::ray_tracer_isa())}};
  j["scene"] = scene_.name;
  j["position"] = {{"name", position_.name},
                   {"floor_point", vec_json(position_.floor_point)},
                   {"start_heading_deg", rad2deg(position_.start_heading_rad)}};
  j["seed"] = options_.seed;
  j["duration_s"] = motion_.duration();
  j["axis"] = {{"point", vec_json(motion_.axis_point())},
               {"direction", vec_json(motion_.axis_direction())},
               {"world_from_axis_at_start", pose_to_json(motion_.world_from_axis(0.0))}};
  j["axis_from_bracket"] = pose_to_json(rig_.axis_from_bracket);
  // The paper's T_u in its own convention: the world is the first frame of the reference camera.
  const auto& reference_frames = schedule_[rig_.reference_sensor];
  if (!reference_frames.empty()) {
    const double t0 = reference_frames.front().timestamp;
    j["axis_in_reference_first_frame"] = pose_to_json(world_from_cam(rig_.reference_sensor, t0).inverse() *
                                                      motion_.world_from_axis(t0 - options_.shutter.start_time_s));
  }
  j["reference_sensor"] = rig_.reference_sensor;
  for (std::size_t c = 0; c < rig_.num_sensors(); ++c) {
    j["sensors"].push_back({{"name", "cam" + std::to_string(c)},
                            {"pitch_deg", rad2deg(rig_.pitches_rad[c])},
                            {"bracket_from_cam", pose_to_json(rig_.bracket_from_cam[c])},
                            {"ref_from_cam_true", pose_to_json(rig_.ref_from_cam_true[c])},
                            {"ref_from_cam_calibrated", pose_to_json(rig_.ref_from_cam_calibrated[c])},
                            {"frames", schedule_[c].size()}});
  }
  const auto& m = options_.motion;
  j["motion"] = {{"kind", to_string(m.kind)},
                 {"turn_deg", m.turn_deg},
                 {"period_s", m.period_s},
                 {"ramp_s", m.ramp_s},
                 {"accel_std_deg_s2", m.accel_std_deg_s2},
                 {"speed_band_hz", {m.speed_band_low_hz, m.speed_band_high_hz}},
                 {"wobble_translation_m", m.wobble_translation_m},
                 {"wobble_rotation_deg", m.wobble_rotation_deg},
                 {"wobble_band_hz", {m.wobble_band_low_hz, m.wobble_band_high_hz}},
                 {"axis_tilt_deg", m.axis_tilt_deg},
                 {"axis_tilt_azimuth_deg", m.axis_tilt_azimuth_deg}};
  if (m.kind == MotionKind::kHandheld)
    j["motion"]["handheld"] = {
        {"duration_s", m.handheld_duration_s}, {"translation_m", m.handheld_translation_m},
        {"height_m", m.handheld_height_m},     {"yaw_deg", m.handheld_yaw_deg},
        {"tilt_deg", m.handheld_tilt_deg},     {"band_hz", {m.handheld_band_low_hz, m.handheld_band_high_hz}}};
  const auto& s = options_.shutter;
  j["shutter"] = {
      {"fps", s.fps}, {"jitter_ms", s.jitter_ms}, {"drift_ppm", s.drift_ppm}, {"start_time_s", s.start_time_s}};
  const auto& n = options_.noise;
  j["noise"] = {{"preset", to_string(n.preset)},
                {"min_depth_m", n.min_depth_m},
                {"max_depth_m", n.max_depth_m},
                {"max_incidence_deg", n.max_incidence_deg},
                {"shift_std_px", n.shift_std_px},
                {"disparity_std", n.effective_disparity_std()},
                {"ir_speckle", n.ir_speckle},
                {"ir_band_fraction", n.ir_band_fraction},
                {"ir_dropout", n.ir_dropout},
                {"ir_disparity_std", n.ir_disparity_std},
                {"exposure", n.exposure},
                {"exposure_std", n.exposure_std},
                {"white_balance_std", n.white_balance_std},
                {"colour_noise_std", n.colour_noise_std}};
  j["output"] = {{"every", options_.output.every},
                 {"frames", options_.output.max_frames},
                 {"clean_depth", options_.output.clean_depth},
                 {"normals", options_.output.normals},
                 {"ids", options_.output.ids}};
  if (options_.output.ids) {
    // What groundtruth/ids' material_id indexes: the names make the ids readable without the scene.
    nlohmann::json names = nlohmann::json::array();
    for (const Material& material : scene_.materials) names.push_back(material.name);
    j["materials"] = names;
  }
  j["calibration_error"] = {{"rotation_deg", options_.rig.calibration_error_deg},
                            {"translation_m", options_.rig.calibration_error_m}};
  return j.dump(2) + "\n";
}

SimulatedFrame Simulator::render_frame(const FrameTime& frame) const { return render_frame(frame, nullptr, false); }

SimulatedFrame Simulator::render_frame(const FrameTime& frame, StageClocks* clocks, bool written_only) const {
  SimulatedFrame out;
  out.sensor = frame.sensor;
  out.index = frame.index;
  out.timestamp = frame.timestamp;
  out.world_from_cam = world_from_cam(frame.sensor, frame.timestamp);
  RenderRequest request;
  request.normals = options_.output.normals;
  request.triangle_ids = !written_only || options_.output.ids;
  RenderedView view =
      renderer_.render(out.world_from_cam, rig_.intrinsics, request, clocks ? &clocks->render : nullptr);

  std::optional<ScopedClock> clock(std::in_place, clocks ? &clocks->depth_noise : nullptr);
  // Noiseless ground-truth depth: the exact z, limited to the sensor's range.
  // Rows in parallel: a serial pass here was 4% of a frame's time.
  if (!written_only || options_.output.clean_depth) {
    out.clean_depth = ImageF32::uninitialised(view.depth.width, view.depth.height, 1);  // every pixel written below
    tbb::parallel_for(tbb::blocked_range<int>(0, view.depth.height, 16), [&](const tbb::blocked_range<int>& rows) {
      const std::size_t begin = std::size_t(rows.begin()) * view.depth.width;
      const std::size_t end = std::size_t(rows.end()) * view.depth.width;
      for (std::size_t i = begin; i < end; ++i) {
        const float z = view.depth.data[i];
        out.clean_depth.data[i] = z < options_.noise.min_depth_m || z > options_.noise.max_depth_m ? 0.f : z;
      }
    });
  }

  DepthNoiseInput input;
  input.clean_depth = &view.depth;
  input.incidence_cos = &view.incidence_cos;
  input.intrinsics = &rig_.intrinsics;
  input.sensor = frame.sensor;
  input.frame = frame.index;
  for (const auto& [lower, upper] : rig_.vertical_neighbours()) {
    // The lower camera's top rows and the upper camera's bottom rows see the same band,
    // lit by both projectors.
    if (frame.sensor == lower) input.speckle_top = true;
    if (frame.sensor == upper) input.speckle_bottom = true;
  }
  out.depth = apply_depth_noise(input, options_.noise, options_.seed);
  clock.emplace(clocks ? &clocks->colour : nullptr);

  const NoiseOptions& noise = options_.noise;
  if (noise.exposure || noise.colour_noise_std > 0) {
    Eigen::Vector3f gain(1.f, 1.f, 1.f);
    if (noise.exposure) {
      // Per camera, constant over the scan (auto-exposure locked after start).
      RandomStream rng(options_.seed, frame.sensor, -1, RandomPurpose::kColour);
      const double exposure = std::max(0.2, 1.0 + rng.normal() * noise.exposure_std);
      for (int c = 0; c < 3; ++c)
        gain[c] = float(exposure * std::max(0.2, 1.0 + rng.normal() * noise.white_balance_std));
    }
    RandomStream pixel_rng(options_.seed, frame.sensor, frame.index, RandomPurpose::kColour);
    for (std::size_t i = 0; i < view.rgb.data.size(); ++i) {
      float value = view.rgb.data[i] * gain[i % 3];
      if (noise.colour_noise_std > 0) value += float(pixel_rng.normal() * noise.colour_noise_std);
      view.rgb.data[i] = static_cast<std::uint8_t>(std::clamp(value + 0.5f, 0.f, 255.f));
    }
  }
  out.rgb = std::move(view.rgb);
  out.triangle_id = std::move(view.triangle_id);
  out.normal_cam = std::move(view.normal_cam);
  if (options_.output.ids) {
    // The scene's materials are the only grouping of triangles a mesh carries (objects made of one
    // material share it), so this is a material/class id, not an instance id.
    const std::vector<int>& triangle_material = scene_.mesh.triangle_material;
    out.material_id = ImageI32(out.triangle_id.width, out.triangle_id.height, 1, -1);
    if (!triangle_material.empty())
      for (std::size_t i = 0; i < out.triangle_id.data.size(); ++i)
        if (out.triangle_id.data[i] >= 0) out.material_id.data[i] = triangle_material[out.triangle_id.data[i]];
  }
  return out;
}

double Simulator::probe_depth_coverage() const {
  // 12 frames per camera spread over its schedule (the whole turn): what the scan will see.
  constexpr int kProbes = 12;
  std::vector<FrameTime> probes;
  for (const auto& frames : schedule_)
    for (int k = 0; k < kProbes && !frames.empty(); ++k) probes.push_back(frames[k * frames.size() / kProbes]);
  std::vector<std::size_t> valid(probes.size(), 0), pixels(probes.size(), 0);
  const int threads = options_.threads > 0 ? options_.threads : tbb::task_arena::automatic;
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(std::size_t(0), probes.size(), [&](std::size_t k) {
      // The clean depth within the sensor's range, as render_frame makes it, without the noise and
      // colour steps that render_frame would spend on a frame that is never written.
      RenderRequest depth_only;
      depth_only.colour = false;
      depth_only.triangle_ids = false;
      const RenderedView view =
          renderer_.render(world_from_cam(probes[k].sensor, probes[k].timestamp), rig_.intrinsics, depth_only);
      for (float z : view.depth.data)
        valid[k] += z > 0.f && z >= options_.noise.min_depth_m && z <= options_.noise.max_depth_m;
      pixels[k] = view.depth.data.size();
    });
  });
  std::size_t valid_sum = 0, pixel_sum = 0;
  for (std::size_t k = 0; k < probes.size(); ++k) {
    valid_sum += valid[k];
    pixel_sum += pixels[k];
  }
  return pixel_sum == 0 ? 0.0 : double(valid_sum) / double(pixel_sum);
}

std::size_t Simulator::write_scan(const std::filesystem::path& scan_dir, bool overwrite, SimStageTimes* times) const {
  const std::int64_t start = now_ns();
  const int num_sensors = int(rig_.num_sensors());
  std::size_t total = 0;
  for (const auto& frames : schedule_) total += frames.size();
  if (total == 0) throw make_error(scan_dir.string(), "output.frames", "the schedule selects no frames");
  if (options_.output.min_depth_coverage > 0.0) {
    const double coverage = probe_depth_coverage();
    if (coverage < options_.output.min_depth_coverage)
      throw make_error(scene_.name, "position " + position_.name,
                       fmt::format("the rig sees almost nothing from here: {:.1f}% of the pixels of a probe of the "
                                   "turn have depth in the sensor's range (at least {:.0f}%, "
                                   "output.min_depth_coverage); is the position outside the room or inside an "
                                   "object?",
                                   100.0 * coverage, 100.0 * options_.output.min_depth_coverage));
  }
  const std::int64_t probed = now_ns();

  ScanWriter writer(scan_dir, rig_info(), overwrite, options_.output.png_compression);
  std::vector<std::vector<StampedPose>> truth(num_sensors);
  Progress progress("simulating " + scene_.name + " " + position_.name, total);
  // Every frame of every camera in time order: the order in which they are written. Each
  // camera's frames stay in time order, as the writer requires.
  std::vector<FrameTime> order;
  order.reserve(total);
  for (const auto& frames : schedule_) order.insert(order.end(), frames.begin(), frames.end());
  std::stable_sort(order.begin(), order.end(),
                   [](const FrameTime& a, const FrameTime& b) { return a.timestamp < b.timestamp; });
  StageClocks clocks;
  const int threads = options_.threads > 0 ? options_.threads : tbb::task_arena::automatic;
  tbb::task_arena arena(threads);
  // A frame's colour and depth PNGs, encoded by a worker, waiting for their turn to be written.
  struct EncodedFrame {
    const FrameTime* frame = nullptr;
    Rigid3d world_from_cam = Rigid3d::Identity();
    std::string rgb_png, depth_png;
  };
  std::size_t next = 0;
  arena.execute([&] {
    // Frames render and encode in parallel (rows in parallel inside each) and are written one at
    // a time in `order`: the PNG encoding, once a third of the time, no longer waits on the other
    // cameras' frames or serialises a camera's frames. Two frames in flight per thread keep the
    // workers busy while one writes.
    tbb::parallel_pipeline(
        std::size_t(2 * arena.max_concurrency()),
        tbb::make_filter<void, std::shared_ptr<EncodedFrame>>(
            tbb::filter_mode::serial_in_order,
            [&](tbb::flow_control& control) -> std::shared_ptr<EncodedFrame> {
              if (next == order.size()) {
                control.stop();
                return nullptr;
              }
              auto encoded = std::make_shared<EncodedFrame>();
              encoded->frame = &order[next++];
              return encoded;
            }) &
            tbb::make_filter<std::shared_ptr<EncodedFrame>, std::shared_ptr<EncodedFrame>>(
                tbb::filter_mode::parallel,
                [&](std::shared_ptr<EncodedFrame> encoded) {
                  const FrameTime& frame = *encoded->frame;
                  const SimulatedFrame simulated = render_frame(frame, &clocks, /*written_only=*/true);
                  encoded->world_from_cam = simulated.world_from_cam;
                  {
                    ScopedClock clock(&clocks.encode);
                    encoded->rgb_png = encode_png(simulated.rgb, options_.output.png_compression);
                    encoded->depth_png =
                        encode_png16(depth_to_png_units(simulated.depth, 5000.0), options_.output.png_compression);
                  }
                  // The optional ground truth has no listing and no order: written here, in parallel.
                  ScopedClock clock(&clocks.ground_truth);
                  if (options_.output.clean_depth)
                    writer.write_clean_depth(frame.sensor, frame.timestamp,
                                             depth_to_png_units(simulated.clean_depth, 5000.0));
                  if (options_.output.normals)
                    writer.write_groundtruth_normals(frame.sensor, frame.timestamp, simulated.normal_cam);
                  if (options_.output.ids)
                    writer.write_groundtruth_ids(frame.sensor, frame.timestamp, simulated.triangle_id,
                                                 simulated.material_id);
                  return encoded;
                }) &
            tbb::make_filter<std::shared_ptr<EncodedFrame>, void>(
                tbb::filter_mode::serial_in_order, [&](std::shared_ptr<EncodedFrame> encoded) {
                  ScopedClock clock(&clocks.write);
                  const FrameTime& frame = *encoded->frame;
                  writer.write_encoded_frame(frame.sensor, frame.timestamp, encoded->rgb_png, encoded->depth_png);
                  truth[frame.sensor].push_back({frame.timestamp, encoded->world_from_cam});
                  progress.advance();
                }));
  });
  progress.finish();
  const std::int64_t rendered = now_ns();
  for (int sensor = 0; sensor < num_sensors; ++sensor) writer.write_groundtruth_trajectory(sensor, truth[sensor]);
  writer.write_groundtruth_file("rig_truth.json", rig_truth_json());
  writer.write_groundtruth_mesh(scene_.mesh);
  writer.commit();
  if (times) {
    const std::int64_t end = now_ns();
    times->probe_s = double(probed - start) * 1e-9;
    times->rays_s = seconds_of(clocks.render.rays_ns);
    times->shading_s = seconds_of(clocks.render.shading_ns);
    times->depth_noise_s = seconds_of(clocks.depth_noise);
    times->colour_s = seconds_of(clocks.colour);
    times->encode_s = seconds_of(clocks.encode);
    times->ground_truth_s = seconds_of(clocks.ground_truth);
    times->write_s = seconds_of(clocks.write);
    times->finish_s = double(end - rendered) * 1e-9;
    times->frame_threads_s = double(rendered - probed) * 1e-9 * arena.max_concurrency();
    times->wall_s = double(end - start) * 1e-9;
    times->frames = total;
    times->pixels = total * std::size_t(rig_.intrinsics.width) * std::size_t(rig_.intrinsics.height);
  }
  return total;
}

}  // namespace panoscan
