// Configuration: a YAML/JSON document (`--config`), then `--set key=value` overrides (the input's
// NUL-separated remainder), then typed reads of the keys the overrides name and of a few fixed ones,
// as option readers do, and the unused-key check.
#include "fuzz_target.h"
#include "panoscan/core/config.h"

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  using namespace std::string_literals;
  return {"sim:\n  seed: 7\n  size: [320, 240]\npanorama:\n  lambda: 0.5\n  method: tsa\n"s,
          "{\"track\": {\"max_iterations\": 40, \"robust\": true}}\0track.max_iterations=12\0panorama.lambda=1e-3"s,
          "a: 1\n\0b.c=[1, 2, 3]\0d=yes\0e=\"text\""s};
}
}  // namespace panoscan::fuzz

namespace {
// Every typed getter on `key`; a mistyped or out-of-range value is an Error naming it.
void read_typed(panoscan::Config& config, const std::string& key, unsigned which) {
  switch (which % 6) {
    case 0: config.get_double(key, 0.5, -1e6, 1e6); break;
    case 1: config.get_int(key, 3, -1000, 1000); break;
    case 2: config.get_u64(key, 1); break;
    case 3: config.get_bool(key, false); break;
    case 4: config.get_string(key, "tsa", {"tsa", "tp", "tv"}); break;
    default: config.get_doubles(key, {1.0, 2.0, 3.0}, 3); break;
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = input.find('\0', start);
    parts.push_back(input.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  panoscan::fuzz::expect_clean("fuzz.yaml", [&] {
    panoscan::Config config = panoscan::Config::from_string(parts[0], "fuzz.yaml");
    std::vector<std::string> keys = {"sim.seed", "panorama.lambda", "track.max_iterations"};
    for (std::size_t k = 1; k < parts.size(); ++k) {
      try {
        config.apply_override(parts[k]);
      } catch (const panoscan::Error& e) {
        // Named by the command line, or by the document when the override clashes with its value.
        const std::string message = e.what();
        if (message.find("fuzz.yaml") == std::string::npos) panoscan::fuzz::check_error_names("command line", e.what());
        continue;
      }
      keys.push_back(parts[k].substr(0, parts[k].find('=')));
    }
    for (std::size_t k = 0; k < keys.size(); ++k) {
      try {
        read_typed(config, keys[k], unsigned(k + parts[0].size()));
      } catch (const panoscan::Error& e) {
        panoscan::fuzz::check_error_names(keys[k], e.what());
      }
    }
    // An unused key is named with where it came from: the document or the command line.
    try {
      config.check_all_used();
    } catch (const panoscan::Error& e) {
      const std::string message = e.what();
      if (message.find("command line") == std::string::npos) panoscan::fuzz::check_error_names("fuzz.yaml", e.what());
    }
  });
  return 0;
}
