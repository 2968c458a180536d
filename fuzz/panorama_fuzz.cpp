// Panorama folders (panorama.json + EXR + flags.png, what `recon panorama` writes and `recon
// register`/`scene` read): the first byte picks which file of a valid 8x16 panorama the rest replaces.
#include "fuzz_target.h"
#include "panoscan/recon/panorama.h"

namespace {
const std::vector<std::string> kFiles = {"panorama.json", "depth.exr", "colour.exr",
                                        "variance.exr",  "count.exr", "flags.png"};

const std::filesystem::path& panorama_dir() {
  static const std::filesystem::path dir = [] {
    const auto d = panoscan::fuzz::scratch_dir() / "panorama";
    panoscan::Panorama p;
    p.pano.height = 8;
    const int w = p.pano.width(), h = p.pano.height;
    p.colour = panoscan::ImageF32(w, h, 3, 0.5f);
    p.depth = panoscan::ImageF32(w, h, 1, 0.f);
    p.variance = panoscan::ImageF32(w, h, 1, 0.f);
    p.count = panoscan::ImageF32(w, h, 1, 0.f);
    p.flagged = panoscan::ImageU8(w, h, 1, 0);
    for (int v = 1; v < h - 1; ++v)
      for (int u = 0; u < w; ++u) {
        p.depth.at(u, v) = 2.0f + 0.1f * u;
        p.variance.at(u, v) = 1e-5f * (1 + v);
        p.count.at(u, v) = float(1 + u % 3);
        p.flagged.at(u, v) = (u == 3) ? 1 : 0;
      }
    p.method = "tsa";
    p.lambda = 0.5;
    p.energy.push_back({});
    panoscan::write_panorama(d, p, /*overwrite=*/true);
    return d;
  }();
  return dir;
}
}  // namespace

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  return folder_seeds(panorama_dir(), kFiles);
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto selected = panoscan::fuzz::select_file(data, size, kFiles.size());
  panoscan::fuzz::with_file_replaced(panorama_dir() / kFiles[selected.choice], selected.bytes, [&] {
    panoscan::fuzz::expect_clean(panorama_dir().string(), [&] {
      const panoscan::Panorama p = panoscan::read_panorama(panorama_dir());
      p.to_point_cloud(false);
    });
  });
  return 0;
}
