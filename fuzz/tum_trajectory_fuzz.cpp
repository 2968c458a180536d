// TUM trajectories ("timestamp tx ty tz qx qy qz qw" per line): read_tum_trajectory on a file.
#include "fuzz_target.h"
#include "panoscan/core/trajectory.h"

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  return {"# timestamp tx ty tz qx qy qz qw\n1.000000 0.1 0.2 1.3 0 0 0 1\n1.033333 0.1 0.2 1.3 0 0 0.0087 0.99996\n",
          "1 0 0 0 0 0 0 1\n2 1e-3 -2 3.5 0.5 0.5 0.5 0.5\n"};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = panoscan::fuzz::scratch_dir() / "trajectory.txt";
  panoscan::fuzz::write_bytes(path, std::string(reinterpret_cast<const char*>(data), size));
  panoscan::fuzz::expect_clean(path.string(), [&] { panoscan::read_tum_trajectory(path); });
  return 0;
}
