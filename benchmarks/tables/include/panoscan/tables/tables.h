// The paper's tables and figures as one-command drivers (docs/ARCHITECTURE.md §14.1, issue "tables"). Each driver
// simulates the built-in scans it needs (cached on disk, keyed by everything that changes
// them), runs the methods in memory and returns its tables; run_and_write() also writes them as
// Markdown, CSV and JSON (settings, version, machine, date) under <out>/<name>/.
//
// Sizes: "quick" is the CI size (320x240, every 16th frame, H = 512, few scans) and "full" the
// size of the record (640x480, every 16th frame as the paper's default n, H = 1024, every
// built-in scan and pair).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "panoscan/eval/report.h"

namespace panoscan::tables {

struct TablesOptions {
  std::string size = "quick";   // quick | full
  std::string noise = "handa";  // a sim noise preset: handa (the paper's) | kinect | handa-icl | none
  std::filesystem::path cache;  // simulated scans; empty = <out>/scans
  std::filesystem::path out;    // results; may be empty for in-memory runs (then cache is required)
  int threads = 0;              // 0 = all cores
  std::uint64_t seed = 1;
  // The built-in scenes' texture density (scene.texture: icl | rich | plain); part of the scan
  // cache key, so scans of one density are never reused for another.
  std::string texture = "icl";
  // Restrict a driver to these scan or pair labels (e.g. "SO-1", "SO-13"); empty = the size's set.
  std::vector<std::string> only;
};

// What one size means. The scan and pair lists are the columns of the tables.
struct SizePreset {
  std::string name;
  int width = 320, height = 240;
  int every = 16;                  // the paper's sparsity n
  int panorama_height = 512;       // H (W = 2H)
  double tsdf_voxel_m = 0.01;      // the TSDF baseline's voxel (5 mm at full size, as BundleFusion)
  std::vector<std::string> scans;  // e.g. SL-1, SO-1
  std::vector<std::string> pairs;  // e.g. SL-12, SO-13
};
SizePreset size_preset(const std::string& size);  // throws Error on an unknown size

// Throws Error naming the field for an unknown size or noise preset or negative threads; called
// before any work so that a typo fails at once.
void check_tables_options(const TablesOptions& options);

// One driver's result: its tables plus free-text notes (e.g. which paper ordering fails).
struct TableRun {
  std::string name;                       // e.g. "table3"
  std::vector<eval::ResultTable> tables;  // the first is the main table
  std::vector<std::string> notes;
  std::string settings_json = "{}";                                       // driver-specific settings, a JSON object
  const eval::ResultTable& table(const std::string& title_prefix) const;  // throws if absent
};

struct TableDriver {
  std::string name;         // table1 ... table6, fig8
  std::string description;  // one line, for `panoscan tables list`
  std::function<TableRun(const TablesOptions&)> run;
};
const std::vector<TableDriver>& table_drivers();
const TableDriver& table_driver(const std::string& name);  // throws Error naming the known ones

// Runs one driver and writes <out>/<name>/<name>.{md,csv,json} (+ any files the driver writes
// itself) atomically. Returns the run.
TableRun run_and_write(const std::string& name, const TablesOptions& options);

// A built-in scan label ("SL-1", "SO-3") -> its simulated scan directory, simulated on first
// use at the preset's size with the options' noise and seed. Safe to call from concurrent
// processes sharing a cache (a file lock per scan). `every` > 0 overrides the preset's sparsity
// (Fig. 8 simulates a dense scan and subsamples it).
std::filesystem::path cached_scan(const std::string& label, const TablesOptions& options, int every = 0);
// "SO-13" -> {"SO-1", "SO-3"}.
std::pair<std::string, std::string> pair_scans(const std::string& pair_label);

}  // namespace panoscan::tables
