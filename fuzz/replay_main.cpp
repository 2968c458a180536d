// Replays a corpus through a fuzz target without libFuzzer (the project's own compiler, CTest label
// `fuzz`): every file of every folder given, in name order, once. `--write-seeds DIR` writes the
// target's seed inputs instead (how the committed corpora were made).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "fuzz_target.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--write-seeds") {
    const fs::path dir = argv[2];
    fs::create_directories(dir);
    const std::vector<std::string> seeds = panoscan::fuzz::seed_inputs();
    for (std::size_t i = 0; i < seeds.size(); ++i)
      panoscan::fuzz::write_bytes(dir / ("seed-" + std::to_string(i)), seeds[i]);
    std::printf("wrote %zu seeds into %s\n", seeds.size(), dir.string().c_str());
    return 0;
  }
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR_OR_FILE... | --write-seeds DIR\n", argv[0]);
    return 2;
  }
  std::size_t replayed = 0;
  for (int a = 1; a < argc; ++a) {
    std::vector<fs::path> files;
    if (fs::is_directory(argv[a])) {
      for (const auto& entry : fs::directory_iterator(argv[a]))
        if (entry.is_regular_file()) files.push_back(entry.path());
      std::sort(files.begin(), files.end());
    } else if (fs::is_regular_file(argv[a])) {
      files.push_back(argv[a]);
    } else {
      std::fprintf(stderr, "%s: not a file or folder\n", argv[a]);
      return 2;
    }
    if (files.empty()) {
      std::fprintf(stderr, "%s: empty corpus\n", argv[a]);
      return 2;
    }
    for (const fs::path& file : files) {
      const std::string bytes = panoscan::fuzz::read_bytes(file);
      LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      ++replayed;
    }
  }
  std::printf("replayed %zu inputs: no finding\n", replayed);
  return 0;
}
