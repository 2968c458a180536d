// What every fuzz target shares (docs/ARCHITECTURE.md §17.3): the libFuzzer entry point, a scratch
// folder for readers that take paths, and the rule that bad input must end in panoscan::Error.
//
// A target defines LLVMFuzzerTestOneInput and seed_inputs(). Built with clang's -fsanitize=fuzzer
// (scripts/fuzz.sh) it is a libFuzzer binary; built by the project's own compiler with replay_main.cpp
// it feeds each file of its committed corpus once (CTest label `fuzz`), so CI replays the corpora
// without a clang build.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace panoscan::fuzz {

// Valid inputs of this target (its seed corpus: `replay --write-seeds DIR` writes them).
std::vector<std::string> seed_inputs();

// A folder of this process (under the system temp folder), created on first use, removed at exit.
const std::filesystem::path& scratch_dir();
void write_bytes(const std::filesystem::path& path, const std::string& bytes);
std::string read_bytes(const std::filesystem::path& path);

// Runs `read` on input that names `origin` (a file or folder path, or a text's origin). A
// panoscan::Error whose message names `origin` is the expected refusal of bad input; an Error that
// does not name it is a finding (the user could not tell which file is wrong), and so is any other
// exception, which escapes to libFuzzer.
template <class Read>
void expect_clean(const std::string& origin, Read&& read);

// Called by expect_clean for an Error: aborts (a finding) when the message does not name `origin`.
void check_error_names(const std::string& origin, const char* message);

// A one-sensor scan of 2 frames of 8x6 pixels written by ScanWriter into `dir` (replaced).
void write_tiny_scan(const std::filesystem::path& dir);

// The bytes of `data` after the first, and which of `choices` files the first byte picks: targets
// that read a folder replace one of its files by the fuzzed bytes.
struct Selected {
  std::size_t choice = 0;
  std::string bytes;
};
Selected select_file(const std::uint8_t* data, std::size_t size, std::size_t choices);

// The seeds of a folder target: for each of `files` (relative to `dir`), its index byte + its bytes.
std::vector<std::string> folder_seeds(const std::filesystem::path& dir, const std::vector<std::string>& files);

// Replaces `path` by `bytes`, runs `read`, and puts the original back (inputs must not leak into the
// next one).
template <class Read>
void with_file_replaced(const std::filesystem::path& path, const std::string& bytes, Read&& read) {
  const std::string original = read_bytes(path);
  write_bytes(path, bytes);
  read();
  write_bytes(path, original);
}

}  // namespace panoscan::fuzz

#include "panoscan/core/error.h"

template <class Read>
void panoscan::fuzz::expect_clean(const std::string& origin, Read&& read) {
  try {
    read();
  } catch (const panoscan::Error& e) {
    check_error_names(origin, e.what());
  }
}
