// The scan simulator: renders one scanning position of a scene with the rig on the wobbling
// rotator and writes the scan (docs/ARCHITECTURE.md §5) with its ground truth. Also usable in memory.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/mesh.h"
#include "panoscan/core/scan.h"
#include "panoscan/sim/motion.h"
#include "panoscan/sim/options.h"
#include "panoscan/sim/renderer.h"
#include "panoscan/sim/rig.h"
#include "panoscan/sim/shutter.h"

namespace panoscan {

struct SimulatedFrame {
  int sensor = 0;
  int index = 0;
  double timestamp = 0.0;
  Rigid3d world_from_cam = Rigid3d::Identity();  // ground truth
  ImageU8 rgb;
  ImageF32 depth;        // noisy (metres, 0 = invalid), before PNG quantisation
  // The two below are made by render_frame; write_scan makes them only where it writes them
  // (output.clean_depth, output.ids).
  ImageF32 clean_depth;  // noiseless z (range-limited), metres
  ImageI32 triangle_id;  // hit triangle of the noiseless ray, -1 = none (every hit, not range-limited)
  ImageF32 normal_cam;   // only with output.normals: RenderedView::normal_cam
  ImageI32 material_id;  // only with output.ids: the hit triangle's scene material, -1 = no hit or no materials
};

// Where a write_scan's time went, by stage. The per-frame stages are thread seconds summed over
// the worker threads; frame_threads_s is the wall time of the frame loop times the threads, so
// what the stages leave of it is idle or unmeasured (scheduling, allocation). probe_s and
// finish_s are wall seconds of the steps before and after the frame loop. For the speed
// benchmarks' counters and `panoscan sim`'s log.
struct SimStageTimes {
  double rays_s = 0;           // primary ray packets (Embree)
  double shading_s = 0;        // hit attributes, texture sampling, lights
  double depth_noise_s = 0;    // range limit of the clean depth and the depth noise model
  double colour_s = 0;         // exposure, white balance, colour noise, material ids
  double encode_s = 0;         // depth to PNG units, colour and depth PNG encoding (in memory)
  double ground_truth_s = 0;   // optional per-frame ground truth files (clean depth PNG, normals and ids EXR)
  double write_s = 0;          // writing the frames' PNG files, in time order (one thread at a time)
  double frame_threads_s = 0;  // wall time of the frame loop x threads
  double probe_s = 0;          // depth-coverage probe (12 frames per camera) before the frame loop
  double finish_s = 0;         // trajectories, rig_truth.json, the mesh, the commit
  double wall_s = 0;           // the whole write_scan
  std::size_t frames = 0;
  std::size_t pixels = 0;  // frames x width x height

  std::string summary() const;  // one line for logs
};

class Simulator {
 public:
  // Validates the options and the position index; `scene` must outlive the simulator.
  Simulator(const Scene& scene, int position_index, const SimOptions& options);
  // The simulator keeps a reference to its scene: a temporary one would be gone after the call
  // (a test did this, and AddressSanitizer found the renderer reading the dead scene).
  Simulator(Scene&& scene, int position_index, const SimOptions& options) = delete;

  const RigModel& rig() const { return rig_; }
  const MotionModel& motion() const { return motion_; }
  const std::vector<std::vector<FrameTime>>& schedule() const { return schedule_; }
  const SimOptions& options() const { return options_; }
  const Renderer& renderer() const { return renderer_; }

  Rigid3d world_from_bracket(double t) const;
  Rigid3d world_from_cam(int sensor, double t) const;  // ground truth
  RigInfo rig_info() const;                            // what rig.json holds (calibrated extrinsics)
  std::string rig_truth_json() const;                  // groundtruth/rig_truth.json

  SimulatedFrame render_frame(const FrameTime& frame) const;

  // Renders every scheduled frame and writes the scan directory atomically. Returns the number
  // of frames written. Uses options().threads threads.
  // Throws Error naming the position when the probe's depth coverage is below
  // options().output.min_depth_coverage (nothing is written then).
  // `times` (optional) receives the stage breakdown. Frames are rendered and encoded in parallel
  // and written in time order: the files do not depend on the thread count.
  std::size_t write_scan(const std::filesystem::path& scan_dir, bool overwrite, SimStageTimes* times = nullptr) const;

  // Share of the pixels with depth in the sensor's range over 12 frames per camera spread over the turn.
  double probe_depth_coverage() const;

 private:
  struct StageClocks;  // simulator.cpp
  // `written_only`: only what write_scan writes (no clean depth or triangle ids unless the output
  // options ask for them: a pass over 1.2 MB and a 1.2 MB copy per 640x480 frame each).
  SimulatedFrame render_frame(const FrameTime& frame, StageClocks* clocks, bool written_only) const;

  const Scene& scene_;
  ScanPosition position_;
  SimOptions options_;
  RigModel rig_;
  MotionModel motion_;
  Renderer renderer_;
  std::vector<std::vector<FrameTime>> schedule_;
};

}  // namespace panoscan
