// A scan folder through the scan reader: the first byte picks which file of a valid one-sensor scan
// the rest replaces (rig.json, the two TUM listings, a depth PNG, a colour PNG); then the index is
// read and every frame loaded, as reconstruction does. The file is restored afterwards.
#include <array>

#include "fuzz_target.h"
#include "panoscan/core/scan.h"

namespace {
const std::array<const char*, 5> kFiles = {"rig.json", "cam0/rgb.txt", "cam0/depth.txt", "cam0/depth/1.000000.png",
                                           "cam0/rgb/1.000000.png"};

const std::filesystem::path& scan_dir() {
  static const std::filesystem::path dir = [] {
    const auto d = panoscan::fuzz::scratch_dir() / "scan";
    panoscan::fuzz::write_tiny_scan(d);
    return d;
  }();
  return dir;
}
}  // namespace

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  std::vector<std::string> seeds;
  for (std::size_t k = 0; k < kFiles.size(); ++k)
    seeds.push_back(std::string(1, char(k)) + read_bytes(scan_dir() / kFiles[k]));
  return seeds;
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto selected = panoscan::fuzz::select_file(data, size, kFiles.size());
  const auto path = scan_dir() / kFiles[selected.choice];
  const std::string original = panoscan::fuzz::read_bytes(path);
  panoscan::fuzz::write_bytes(path, selected.bytes);
  panoscan::fuzz::expect_clean(scan_dir().string(), [&] {
    const panoscan::ScanIndex scan = panoscan::read_scan_index(scan_dir());
    for (std::size_t s = 0; s < scan.frames.size(); ++s)
      for (std::size_t f = 0; f < scan.frames[s].size(); ++f) panoscan::load_frame(scan, int(s), f);
  });
  panoscan::fuzz::write_bytes(path, original);
  return 0;
}
