// Load (issue "reliability"): processes that share a cache, and more threads than cores. Nothing
// may be corrupted and the results must equal those of a run on its own.
//  - Two `panoscan tables` processes started together on one cold cache: they simulate the same
//    scans and build the same panoramas at the same time (the cache is file-locked per entry, and
//    every entry is written to a temporary folder and renamed into place). Both must produce the
//    table a single process on a cache of its own produces, byte for byte, and leave no temporary
//    folder behind.
//  - `sim` with 4x as many threads as the machine has cores writes the same bytes as with one.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_util.h"
#include "test_util.h"

namespace fs = std::filesystem;
using panoscan::testutil::run_panoscan;

namespace {

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Every regular file under `root`, relative, sorted.
std::vector<std::string> files_under(const fs::path& root) {
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.is_regular_file()) files.push_back(fs::relative(entry.path(), root).string());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::string> leftover_temporaries(const fs::path& root) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.path().filename().string().find(".tmp-") != std::string::npos) found.push_back(entry.path().string());
  return found;
}

std::string shell_quote(const std::string& s) { return "'" + s + "'"; }

}  // namespace

TEST(Load, TwoTablesProcessesOnOneCacheEqualASingleRun) {
  panoscan::testutil::TempDir tmp("load-tables");
  const std::string binary = std::string(PANOSCAN_BINARY_DIR) + "/app/panoscan";
  auto command = [&](const std::string& cache, const std::string& out) {
    return binary + " tables table5 --size quick --only SO-13 --seed 1 --threads 1 --cache " +
           shell_quote((tmp / cache).string()) + " --out " + shell_quote((tmp / out).string());
  };
  // Both at once on the shared cache (each writes its exit code beside its log), then alone.
  const std::string together = "(" + command("shared", "a") + " > " + shell_quote((tmp / "a.log").string()) +
                               " 2>&1; echo $? > " + shell_quote((tmp / "a.rc").string()) + ") & (" +
                               command("shared", "b") + " > " + shell_quote((tmp / "b.log").string()) +
                               " 2>&1; echo $? > " + shell_quote((tmp / "b.rc").string()) + ") & wait";
  ASSERT_EQ(std::system(("sh -c " + shell_quote(together)).c_str()), 0);
  for (const char* name : {"a", "b"})
    ASSERT_EQ(file_bytes(tmp / (std::string(name) + ".rc")), "0\n") << file_bytes(tmp / (std::string(name) + ".log"));
  const int alone = std::system((command("own", "single") + " > " + shell_quote((tmp / "single.log").string()) + " 2>&1").c_str());
  ASSERT_EQ(alone, 0) << file_bytes(tmp / "single.log");

  const fs::path table = fs::path("handa") / "table5" / "table5.csv";
  const std::string reference = file_bytes(tmp / "single" / table);
  ASSERT_FALSE(reference.empty());
  EXPECT_EQ(file_bytes(tmp / "a" / table), reference);
  EXPECT_EQ(file_bytes(tmp / "b" / table), reference);
  // The shared cache holds what the single run's cache holds, and nothing half-written.
  EXPECT_TRUE(leftover_temporaries(tmp / "shared").empty());
  std::vector<std::string> shared = files_under(tmp / "shared"), own = files_under(tmp / "own");
  EXPECT_EQ(shared, own);
  for (const std::string& file : own) {
    if (file.find("rig.json") != std::string::npos || file.find(".png") != std::string::npos) {
      EXPECT_EQ(file_bytes(tmp / "shared" / file), file_bytes(tmp / "own" / file)) << file;
    }
  }
}

TEST(Load, SimWithMoreThreadsThanCoresWritesTheSameScan) {
  panoscan::testutil::TempDir tmp("load-sim");
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const std::string common = "sim --scene office --position SO-1 --resolution 80x60 --every 40 --seed 3 --out ";
  const auto one = run_panoscan(common + (tmp / "one").string() + " --threads 1");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const auto many = run_panoscan(common + (tmp / "many").string() + " --threads " + std::to_string(4 * cores));
  ASSERT_EQ(many.exit_code, 0) << many.output;
  const std::vector<std::string> files = files_under(tmp / "one");
  ASSERT_EQ(files_under(tmp / "many"), files);
  ASSERT_GT(files.size(), 10u);
  for (const std::string& file : files)
    EXPECT_EQ(file_bytes(tmp / "one" / file), file_bytes(tmp / "many" / file)) << file;
}
