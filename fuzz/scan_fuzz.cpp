// A scan folder through the scan reader: the first byte picks which file of a valid one-sensor scan
// the rest replaces (rig.json, the two TUM listings, a depth PNG, a colour PNG); then the index is
// read and every frame loaded, as reconstruction does. The file is restored afterwards.
#include "fuzz_target.h"
#include "panoscan/core/scan.h"

namespace {
const std::vector<std::string> kFiles = {"rig.json", "cam0/rgb.txt", "cam0/depth.txt", "cam0/depth/1.000000.png",
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
  return folder_seeds(scan_dir(), kFiles);
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto selected = panoscan::fuzz::select_file(data, size, kFiles.size());
  panoscan::fuzz::with_file_replaced(scan_dir() / kFiles[selected.choice], selected.bytes, [&] {
    panoscan::fuzz::expect_clean(scan_dir().string(), [&] {
      const panoscan::ScanIndex scan = panoscan::read_scan_index(scan_dir());
      for (std::size_t s = 0; s < scan.frames.size(); ++s)
        for (std::size_t f = 0; f < scan.frames[s].size(); ++f) panoscan::load_frame(scan, int(s), f);
    });
  });
  return 0;
}
