#include "fuzz_target.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <system_error>

#include "panoscan/core/image.h"
#include "panoscan/core/scan.h"

namespace fs = std::filesystem;

namespace panoscan::fuzz {

namespace {

struct ScratchDir {
  fs::path path;
  ScratchDir() : path(fs::temp_directory_path() / ("panoscan-fuzz-" + std::to_string(::getpid()))) {
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

}  // namespace

const fs::path& scratch_dir() {
  static const ScratchDir dir;
  return dir.path;
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.string().c_str());
    std::abort();
  }
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

void check_error_names(const std::string& origin, const char* message) {
  if (std::string(message).find(origin) != std::string::npos) return;
  std::fprintf(stderr, "fuzz finding: an Error that does not name '%s': %s\n", origin.c_str(), message);
  std::abort();
}

void write_tiny_scan(const fs::path& dir) {
  std::error_code ignored;
  fs::remove_all(dir, ignored);
  RigInfo rig;
  SensorInfo sensor;
  sensor.name = "cam0";
  sensor.intrinsics = PinholeIntrinsics::primesense(8, 6);
  rig.sensors.push_back(sensor);
  rig.description = "fuzz template";
  ScanWriter writer(dir, rig, /*overwrite=*/true);
  for (int frame = 0; frame < 2; ++frame) {
    ImageU8 rgb(8, 6, 3);
    ImageU16 depth(8, 6, 1);
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 8; ++x) {
        for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = static_cast<std::uint8_t>(30 * x + 20 * y + 50 * c + frame);
        depth.at(x, y) = static_cast<std::uint16_t>(x == 0 ? 0 : 5000 + 100 * x + 10 * y);
      }
    writer.write_frame(0, 1.0 + frame / 30.0, rgb, depth);
  }
  writer.commit();
}

Selected select_file(const std::uint8_t* data, std::size_t size, std::size_t choices) {
  Selected selected;
  if (size == 0) return selected;
  selected.choice = data[0] % choices;
  selected.bytes.assign(reinterpret_cast<const char*>(data) + 1, size - 1);
  return selected;
}

std::vector<std::string> folder_seeds(const fs::path& dir, const std::vector<std::string>& files) {
  std::vector<std::string> seeds;
  for (std::size_t k = 0; k < files.size(); ++k) seeds.push_back(std::string(1, char(k)) + read_bytes(dir / files[k]));
  return seeds;
}

}  // namespace panoscan::fuzz
