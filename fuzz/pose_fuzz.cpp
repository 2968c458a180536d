// Pose files: a pose JSON (`recon register --initial`, or a register output), the same bytes as a 4x4
// text matrix (a .txt pose file, what `recon register --matrix` writes), and a tracked rig
// trajectory folder (rig_estimate.json + camK.txt, `recon panorama --trajectory`) read against a valid
// scan. The first byte picks the file the rest becomes.
#include "fuzz_target.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/recon/rig_trajectory.h"

namespace {
const std::vector<std::string> kFiles = {"pose.json", "trajectory/rig_estimate.json", "trajectory/cam0.txt"};

struct Fixture {
  std::filesystem::path root;
  panoscan::ScanIndex scan;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture made;
    made.root = panoscan::fuzz::scratch_dir() / "pose";
    panoscan::fuzz::write_tiny_scan(made.root / "scan");
    made.scan = panoscan::read_scan_index(made.root / "scan");
    panoscan::RigTrajectory trajectory;
    trajectory.world_from_cam.resize(1);
    for (const auto& frame : made.scan.frames[0])
      trajectory.world_from_cam[0].push_back({frame.timestamp, panoscan::Rigid3d::Identity()});
    trajectory.ref_from_cam = {panoscan::Rigid3d::Identity()};
    trajectory.source = "tracked";
    panoscan::write_rig_trajectory(made.root / "trajectory", trajectory, made.scan.rig);
    panoscan::fuzz::write_bytes(made.root / "pose.json",
                                R"({"target_from_source": {"translation": [0.5, -1, 0],)"
                                R"( "rotation_quaternion_xyzw": [0, 0, 0.70710678, 0.70710678]}})");
    return made;
  }();
  return f;
}
}  // namespace

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  std::vector<std::string> seeds = folder_seeds(fixture().root, kFiles);
  seeds.push_back(std::string(1, char(0)) +
                  R"({"translation": [1, 2, 3], "rotation_quaternion_xyzw": [0, 0, 0, 1]})");
  seeds.push_back(std::string(1, char(0)) + "# a matrix\n0 -1 0 0.5\n1 0 0 -1\n0 0 1 0\n0 0 0 1\n");
  return seeds;
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const Fixture& f = fixture();
  const auto selected = panoscan::fuzz::select_file(data, size, kFiles.size());
  const auto path = f.root / kFiles[selected.choice];
  panoscan::fuzz::with_file_replaced(path, selected.bytes, [&] {
    if (selected.choice == 0) {
      panoscan::fuzz::expect_clean(path.string(), [&] { panoscan::read_pose_file(path); });
      const auto matrix = f.root / "pose.txt";
      panoscan::fuzz::write_bytes(matrix, selected.bytes);
      panoscan::fuzz::expect_clean(matrix.string(), [&] { panoscan::read_pose_file(matrix); });
    } else
      panoscan::fuzz::expect_clean((f.root / "trajectory").string(),
                                   [&] { panoscan::read_rig_trajectory(f.root / "trajectory", f.scan); });
  });
  return 0;
}
