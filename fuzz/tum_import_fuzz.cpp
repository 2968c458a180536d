// `import tum` on a TUM sequence folder: the first byte picks which file of a valid two-frame
// sequence (8x6 images) the rest replaces (rgb.txt, depth.txt, groundtruth.txt, a depth PNG, a
// colour PNG); then import_tum writes a scan from it and the scan is read back. The file is
// restored afterwards.
#include "fuzz_target.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/tum_import.h"

namespace {
namespace fs = std::filesystem;
const std::vector<std::string> kFiles = {"rgb.txt", "depth.txt", "groundtruth.txt", "depth/1.004000.png",
                                           "rgb/1.000000.png"};

// Sequence and output under one folder, so that every refusal names it.
const fs::path& root_dir() {
  static const fs::path dir = [] {
    const fs::path d = panoscan::fuzz::scratch_dir() / "tum_import";
    const fs::path seq = d / "seq";
    fs::create_directories(seq / "rgb");
    fs::create_directories(seq / "depth");
    for (const char* t : {"1.000000", "1.033333"}) {
      panoscan::ImageU8 rgb(8, 6, 3, 40);
      rgb.at(1, 2, 0) = 200;
      panoscan::write_png(seq / "rgb" / (std::string(t) + ".png"), rgb);
    }
    for (const char* t : {"1.004000", "1.037333"}) {
      panoscan::ImageU16 depth(8, 6, 1, 5000);
      depth.at(0, 0) = 0;
      panoscan::write_png16(seq / "depth" / (std::string(t) + ".png"), depth);
    }
    panoscan::fuzz::write_bytes(seq / "rgb.txt",
                                "# timestamp filename\n1.000000 rgb/1.000000.png\n1.033333 rgb/1.033333.png\n");
    panoscan::fuzz::write_bytes(seq / "depth.txt",
                                "# timestamp filename\n1.004000 depth/1.004000.png\n1.037333 depth/1.037333.png\n");
    panoscan::fuzz::write_bytes(seq / "groundtruth.txt",
                                "# timestamp tx ty tz qx qy qz qw\n0.995 0 0 1 0 0 0 1\n1.005 0.01 0 1 0 0 0.01 1\n"
                                "1.03 0.02 0 1 0 0 0.02 1\n1.04 0.03 0 1 0 0 0.03 1\n");
    return d;
  }();
  return dir;
}
}  // namespace

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() { return folder_seeds(root_dir() / "seq", kFiles); }
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto selected = panoscan::fuzz::select_file(data, size, kFiles.size());
  panoscan::fuzz::with_file_replaced(root_dir() / "seq" / kFiles[selected.choice], selected.bytes, [&] {
    panoscan::fuzz::expect_clean(root_dir().string(), [&] {
      panoscan::TumImportOptions options;
      options.inputs = {root_dir() / "seq"};
      options.out = root_dir() / "out";
      options.intrinsics = {"6,6,3.5,2.5"};
      options.overwrite = true;
      panoscan::import_tum(options);
      const panoscan::ScanIndex scan = panoscan::read_scan_index(options.out);
      for (std::size_t f = 0; f < scan.frames[0].size(); ++f) panoscan::load_frame(scan, 0, f);
    });
  });
  return 0;
}
