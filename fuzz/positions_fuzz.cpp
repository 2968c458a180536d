// <stem>.positions.json (scanning positions and lights of a scene file).
#include "fuzz_target.h"
#include "panoscan/scenes/scenes.h"

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  return {R"({"format": "panoscan-positions", "version": 1,
 "positions": [{"name": "SO-1", "floor_point": [2.3, 2.0, 0.0], "start_heading_deg": 15.0},
               {"name": "SO-2", "floor_point": [4.3, 3.6, 0.0]}],
 "lights": [{"position": [3.0, 2.5, 2.6], "intensity": 0.8}, {"position": [1, 1, 2.6]}]}
)"};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = panoscan::fuzz::scratch_dir() / "room.positions.json";
  panoscan::fuzz::write_bytes(path, std::string(reinterpret_cast<const char*>(data), size));
  panoscan::fuzz::expect_clean(path.string(), [&] {
    panoscan::Scene scene;
    panoscan::scenes::read_positions_file(path, scene);
  });
  return 0;
}
