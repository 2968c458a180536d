// `panoscan import tum`: reading the arguments, calling core's import_tum (tum_import.h), reporting.
#include <iostream>

#include <fmt/format.h>

#include "commands.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/tum_import.h"

namespace panoscan::app {

void run_import_tum(const ImportTumArguments& a) {
  TumImportOptions options;
  for (const std::string& input : a.inputs) options.inputs.emplace_back(input);
  options.out = a.out;
  options.intrinsics = a.intrinsics;
  options.cameras = a.cameras;
  options.extrinsics_file = a.extrinsics;
  options.depth_scale = a.depth_scale;
  options.max_dt = a.max_dt;
  options.hard_link = a.hard_link;
  options.motion = rig_motion_from_string(a.motion, "--motion", "");
  options.overwrite = a.overwrite;
  const TumImportReport report = import_tum(options);
  for (std::size_t k = 0; k < report.sensors.size(); ++k) {
    const TumImportSensorReport& s = report.sensors[k];
    const SensorInfo& info = report.rig.sensors[k];
    std::string truth = "no groundtruth.txt";
    if (s.has_groundtruth) truth = fmt::format("ground truth for {} of {} frames", s.frames_with_pose, s.frames);
    std::cout << fmt::format(
        "{} <- {}: {} frames {}x{} (colour {} listed, {} dropped; depth {} listed, {} dropped; max |dt| {:.1f} ms), "
        "intrinsics {} ({}), {}\n",
        info.name, s.input.string(), s.frames, info.intrinsics.width, info.intrinsics.height, s.rgb_listed,
        s.rgb_dropped, s.depth_listed, s.depth_dropped, 1e3 * s.max_abs_dt,
        fmt::format("{:g},{:g},{:g},{:g}", info.intrinsics.fx, info.intrinsics.fy, info.intrinsics.cx,
                    info.intrinsics.cy),
        s.intrinsics_source, truth);
  }
  std::cout << fmt::format("wrote {} ({} sensor(s), motion {}; provenance in import.json)\n", a.out,
                           report.rig.sensors.size(), to_string(report.rig.motion));
}

}  // namespace panoscan::app
