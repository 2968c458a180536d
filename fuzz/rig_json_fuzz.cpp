// rig.json (the scan's sensors, intrinsics, depth scale, extrinsics): rig_from_json on the raw text.
#include "fuzz_target.h"
#include "panoscan/core/scan.h"

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  RigInfo rig;
  SensorInfo sensor;
  for (int k = 0; k < 3; ++k) {
    sensor.name = "cam" + std::to_string(k);
    // The reference sensor (0) sits at the identity; the others are tilted and offset.
    sensor.ref_from_cam = make_rigid(Eigen::Quaterniond(Eigen::AngleAxisd(0.7 * k, Eigen::Vector3d::UnitX())),
                                     Eigen::Vector3d(0.0, 0.05 * k, 0.0));
    rig.sensors.push_back(sensor);
  }
  rig.description = "seed";
  return {rig_to_json(rig)};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  panoscan::fuzz::expect_clean("rig.json", [&] { panoscan::rig_from_json(text, "rig.json"); });
  return 0;
}
