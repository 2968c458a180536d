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
  // Restrict a driver to these scan or pair labels (e.g. "SO-1", "SO-13", "GO3-12"); empty = every
  // scan and pair of `scenes`.
  std::vector<std::string> only;
  // The rooms measured, in column order: "builtin" (the size preset's SL/SO scans and pairs),
  // "generated:N" (the seeded generator's rooms 1..N: offices for odd seeds, living rooms for even;
  // scan <prefix>-1 and pair <prefix>-12 of each, prefix GO<seed> or GL<seed>), or a scene file
  // (mesh + <stem>.positions.json: scan <stem>-1, pair <stem>-12).
  std::vector<std::string> scenes = {"builtin"};
  // A stage's refusal (panoscan::Refusal: e.g. tracking that fails its self-check) ends the run as a
  // record of the refusal (TableRun::failures, no cells) instead of an error, so that a multi-seed
  // record counts it as an outcome. Meant for one column per run (--only), as the workflow runs it:
  // the columns measured before the refusal are not kept.
  bool record_refusals = false;
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

// Throws Error naming the field for an unknown size or noise preset, negative threads or a bad
// scene entry; called before any work so that a typo fails at once.
void check_tables_options(const TablesOptions& options);

// The columns of a run: the scans (per-scan tables) and pairs (registration tables) of
// options.scenes, or the scan-like ("SO-1") and pair-like ("SO-13") labels of options.only.
std::vector<std::string> scan_labels(const TablesOptions& options);
std::vector<std::string> pair_labels(const TablesOptions& options);

// A claim of the paper that a table tests: in the table whose title starts with `table`, method
// `better` beats method `worse` (lower or higher by the table's lower_is_better) in every column.
// Multi-seed runs report each as a paired difference with its confidence interval.
struct Claim {
  std::string table;  // a title prefix, e.g. "Table 4:"
  std::string better, worse;
  std::string statement;  // e.g. "the measured variance beats a constant sigma_z"
};

// A column (or a method in it) that gave no value in a run because a stage failed or refused:
// recorded so that the merged cells' n and the claims are read against the runs that failed.
struct ColumnFailure {
  std::string column;  // e.g. "GO7-1", "GO1-12"
  std::string what;    // e.g. "tracking refused", "ORB guess failed (ground-truth poses)"
  std::string reason;  // the stage's one-line message
};

// One driver's result: its tables plus free-text notes (e.g. which paper ordering fails).
struct TableRun {
  std::string name;                       // e.g. "table3"
  std::vector<eval::ResultTable> tables;  // the first is the main table
  std::vector<std::string> notes;
  std::vector<ColumnFailure> failures;
  std::vector<Claim> claims;
  std::string settings_json = "{}";                                       // driver-specific settings, a JSON object
  const eval::ResultTable& table(const std::string& title_prefix) const;  // throws if absent
};

// One column of a driver's tables and the scans it reads: what a workflow schedules before the run
// (`panoscan tables columns NAME`); `label` is what --only takes to run that column alone.
struct Column {
  std::string label;               // e.g. "SO-1", "SO-13", "SO" (Table 5's office pose graph)
  std::vector<std::string> scans;  // e.g. {"SO-1", "SO-3"}
};
std::vector<Column> scan_columns(const TablesOptions& options);  // one per scan_labels()
std::vector<Column> pair_columns(const TablesOptions& options);  // one per pair_labels()

struct TableDriver {
  std::string name;         // table1 ... table6, fig8
  std::string description;  // one line, for `panoscan tables list`
  std::function<TableRun(const TablesOptions&)> run;
  std::function<std::vector<Column>(const TablesOptions&)> columns = scan_columns;
};
const std::vector<TableDriver>& table_drivers();
const TableDriver& table_driver(const std::string& name);  // throws Error naming the known ones

// Runs one driver and writes <out>/<name>/<name>.{md,csv,json} (+ any files the driver writes
// itself) atomically. Returns the run.
TableRun run_and_write(const std::string& name, const TablesOptions& options);

// Runs one driver once per seed (each a run_and_write into <out>/<name>/runs/seed<S>/) and merges
// the runs into <out>/<name>/ (merge_and_write). One seed: run_and_write alone, today's output.
void run_seeds_and_write(const std::string& name, const TablesOptions& options, const std::vector<std::uint64_t>& seeds);

// Reads the records of table runs (folders holding <name>/<name>.json or <name>.json, or the JSON
// files themselves; any tables, seeds and scans) and writes, per table and noise preset,
// <out>/<noise>/<name>/<name>.{md,csv,json} with each cell's mean, 95% Student-t interval and n over
// the seeds, and each claim's paired difference; plus <out>/claims.md over all of them. The output
// depends only on the records' contents (not their paths or order), so that merging the same runs
// anywhere gives the same bytes. Throws Error naming the record for a record that is not a table
// run, runs of different sizes, textures or source revisions, or two differing values for one
// cell and seed. Returns the merged tables' folders.
std::vector<std::filesystem::path> merge_and_write(const std::vector<std::filesystem::path>& records,
                                                   const std::filesystem::path& out);

// Parses "3", "1-8", "1,3,5-7" into seeds (ascending, distinct); throws Error naming --seeds.
std::vector<std::uint64_t> parse_seed_list(const std::string& text);

// A scan label ("SL-1", "SO-3", "GO7-2", "<file stem>-1") -> its simulated scan directory, simulated
// on first use at the preset's size with the options' noise and seed. The cache key names the
// label, scene, size, sparsity, noise, seed, texture and the source revision (so that changed code
// never reuses an old scan). Safe to call from concurrent
// processes sharing a cache (a file lock per scan). `every` > 0 overrides the preset's sparsity
// (Fig. 8 simulates a dense scan and subsamples it).
std::filesystem::path cached_scan(const std::string& label, const TablesOptions& options, int every = 0);
// "SO-13" -> {"SO-1", "SO-3"}; "GO7-12" -> {"GO7-1", "GO7-2"}.
std::pair<std::string, std::string> pair_scans(const std::string& pair_label);

}  // namespace panoscan::tables
