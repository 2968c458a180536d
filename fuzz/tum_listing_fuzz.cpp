// TUM listings ("timestamp filename" per line): read_tum_listing on a file whose entries may name
// the two images of a scratch folder, then associate_timestamps of what it read with a fixed depth
// listing and with itself (as `import tum` pairs colour and depth).
#include "fuzz_target.h"
#include "panoscan/core/tum_listing.h"

namespace {
const std::filesystem::path& base_dir() {
  static const std::filesystem::path dir = [] {
    const auto d = panoscan::fuzz::scratch_dir() / "tum_listing";
    std::filesystem::create_directories(d / "rgb");
    panoscan::fuzz::write_bytes(d / "rgb" / "1.000000.png", "x");
    panoscan::fuzz::write_bytes(d / "rgb" / "1.033333.png", "x");
    return d;
  }();
  return dir;
}
}  // namespace

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  return {"# color images\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp filename\n"
          "1.000000 rgb/1.000000.png\n1.033333 rgb/1.033333.png\n",
          "1 rgb/1.000000.png\r\n\r\n  # comment\r\n1.5\trgb/1.033333.png\r\n",
          "# timestamp filename\n1305031102.175304 rgb/1.000000.png\n1305031102.211214 rgb/1.033333.png\n"};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = base_dir() / "rgb.txt";
  panoscan::fuzz::write_bytes(path, std::string(reinterpret_cast<const char*>(data), size));
  panoscan::fuzz::expect_clean(path.string(), [&] {
    const std::vector<panoscan::TumListingEntry> entries = panoscan::read_tum_listing(path, base_dir());
    std::vector<double> times;
    for (const panoscan::TumListingEntry& entry : entries) times.push_back(entry.timestamp);
    panoscan::associate_timestamps(times, {1.0, 1.004, 1.037, 1305031102.18}, 0.02);
    panoscan::associate_timestamps(times, times, 0.02);
  });
  return 0;
}
