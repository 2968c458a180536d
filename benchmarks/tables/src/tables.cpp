// The table registry, the size presets, the scan cache and the report writer.
#include "panoscan/core/timer.h"
#include "panoscan/tables/tables.h"

#include <chrono>
#include <ctime>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cache_lock.h"
#include "drivers.h"
#include "scene_catalog.h"
#include "panoscan/core/atomic_output.h"
#include "panoscan/core/config.h"
#include "panoscan/core/cpu_features.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/log.h"
#include "panoscan/core/version.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"

namespace fs = std::filesystem;

namespace panoscan::tables {

SizePreset size_preset(const std::string& size) {
  SizePreset p;
  p.name = size;
  if (size == "quick") {
    // CI size: one scan of each scene, one pair.
    p.width = 320;
    p.height = 240;
    p.every = 16;
    p.panorama_height = 512;
    p.tsdf_voxel_m = 0.01;
    p.scans = {"SO-1", "SL-1"};
    p.pairs = {"SO-13"};
  } else if (size == "full") {
    // The record: the paper's camera resolution and sparsity, every built-in scan and pair.
    p.width = 640;
    p.height = 480;
    p.every = 16;
    p.panorama_height = 1024;
    p.tsdf_voxel_m = 0.005;
    p.scans = {"SL-1", "SL-2", "SO-1", "SO-2", "SO-3", "SO-4"};
    p.pairs = {"SL-12", "SO-13", "SO-14", "SO-23", "SO-24"};
  } else {
    throw make_error("--size", "", "unknown size '" + size + "' (known: quick, full)");
  }
  return p;
}

void check_tables_options(const TablesOptions& options) {
  size_preset(options.size);
  // The sim's own validation names the key (noise.preset) and the known presets.
  Config config;
  config.set("noise.preset", options.noise);
  sim_options_from_config(config);
  if (options.threads < 0) throw make_error("--threads", "", "must not be negative");
  scenes::texture_density_from_string(options.texture, "scene.texture");
  check_scene_list(options);
}

const eval::ResultTable& TableRun::table(const std::string& title_prefix) const {
  for (const auto& t : tables)
    if (t.title.rfind(title_prefix, 0) == 0) return t;
  throw make_error(name, "table", "no table titled '" + title_prefix + "...'");
}

const std::vector<TableDriver>& table_drivers() {
  static const std::vector<TableDriver> drivers = all_drivers();
  return drivers;
}

const TableDriver& table_driver(const std::string& name) {
  std::string known;
  for (const auto& d : table_drivers()) {
    if (d.name == name) return d;
    known += (known.empty() ? "" : ", ") + d.name;
  }
  throw make_error("tables", "name", "unknown table '" + name + "' (known: " + known + ")");
}

std::pair<std::string, std::string> pair_scans(const std::string& label) {
  // "SO-13" -> SO-1, SO-3: a scene prefix, a dash, two single-digit positions.
  const auto dash = label.rfind('-');
  if (dash == std::string::npos || label.size() != dash + 3)
    throw make_error("pair", label, "expected a pair label like SO-13");
  const std::string prefix = label.substr(0, dash + 1);
  return {prefix + label[dash + 1], prefix + label[dash + 2]};
}

namespace {

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return text;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  return "unknown";
}

// The scans a table run used and the source revision that rendered each (rig_truth.json's
// rendered_by), for the JSON record: the cache is keyed by settings, not by code.
std::mutex scans_used_mutex;
std::map<std::string, std::string> scans_used;

void record_scan_used(const fs::path& dir) {
  std::string revision = "not recorded (rendered before revisions were recorded)";
  try {
    const nlohmann::json truth = read_json_file(dir / "groundtruth" / "rig_truth.json");
    if (truth.contains("rendered_by") && truth["rendered_by"].contains("source_revision"))
      revision = truth["rendered_by"]["source_revision"].get<std::string>();
  } catch (const std::exception&) {
    revision = "unreadable rig_truth.json";
  }
  std::lock_guard<std::mutex> guard(scans_used_mutex);
  scans_used[dir.filename().string()] = revision;
}

}  // namespace

fs::path cached_scan(const std::string& label, const TablesOptions& options, int every) {
  const SizePreset preset = size_preset(options.size);
  if (every <= 0) every = preset.every;
  const fs::path cache = options.cache.empty() ? options.out / "scans" : options.cache;
  if (cache.empty()) throw make_error("tables", "cache", "no scan cache folder given");
  fs::create_directories(cache);
  const LabelledScene scene = scene_for_label(label, options);
  // The key names everything that changes the scan, the code included: a scan rendered by another
  // revision is never reused (a dirty tree's revision carries a hash of its diff, see
  // cmake/SourceRevision.cmake), nor one rendered with other ray-tracing kernels (a cache shared by
  // machines of different CPUs; core/cpu_features.h).
  const std::string key =
      fmt::format("{}_{}_{}x{}_n{}_{}_seed{}_tex-{}_rt-{}_rev-{}", label, scene.key, preset.width, preset.height, every,
                  options.noise, options.seed, options.texture, cpu::ray_tracer_isa(), source_revision());
  const fs::path dir = cache / key;
  CacheLock lock(cache / (key + ".lock"));
  if (fs::exists(dir / "rig.json")) {
    record_scan_used(dir);
    return dir;
  }
  // Through the config path, so that the noise name is validated like `panoscan sim --noise`.
  Config config;
  config.set("camera.width", std::to_string(preset.width));
  config.set("camera.height", std::to_string(preset.height));
  config.set("output.every", std::to_string(every));
  config.set("seed", std::to_string(options.seed));
  config.set("noise.preset", options.noise);
  if (options.threads > 0) config.set("threads", std::to_string(options.threads));
  const SimOptions sim = sim_options_from_config(config);
  config.check_all_used();
  log_info(fmt::format("tables: simulating {} into {}", label, dir.string()));
  Simulator(*scene.scene, scene.position, sim).write_scan(dir, true);
  record_scan_used(dir);
  return dir;
}

TableRun run_and_write(const std::string& name, const TablesOptions& options) {
  const TableDriver& driver = table_driver(name);
  check_tables_options(options);
  if (options.out.empty()) throw make_error("tables", "--out", "an output folder is required");
  {
    std::lock_guard<std::mutex> guard(scans_used_mutex);
    scans_used.clear();
  }
  const auto start = std::chrono::steady_clock::now();
  TableRun run;
  try {
    run = driver.run(options);
  } catch (const Refusal& e) {
    if (!options.record_refusals) throw;
    // The refusal is the run's outcome (tables.h: record_refusals): no cells, one failure.
    std::string columns;
    for (const std::string& label : options.only.empty() ? scan_labels(options) : options.only)
      columns += (columns.empty() ? "" : ",") + label;
    run = TableRun{};
    run.failures.push_back({columns, "refused", e.what()});
    run.notes.push_back(fmt::format("{}: refused (the run records the refusal): {}", columns, e.what()));
    log_warn(fmt::format("tables: {} {}: refused, recorded as the run's outcome: {}", name, columns, e.what()));
  }
  run.name = name;
  const double seconds = seconds_since(start);

  const fs::path dir = options.out / name;
  fs::create_directories(dir);
  std::string markdown;
  for (const auto& t : run.tables) markdown += eval::table_to_markdown(t) + "\n";
  if (!run.notes.empty()) {
    markdown += "Notes:\n";
    for (const auto& n : run.notes) markdown += "- " + n + "\n";
  }
  write_file_atomic(dir / (name + ".md"), markdown);
  std::string csv;
  for (const auto& t : run.tables) csv += "# " + t.title + " (" + t.unit + ")\n" + eval::table_to_csv(t);
  write_file_atomic(dir / (name + ".csv"), csv);

  const SizePreset preset = size_preset(options.size);
  nlohmann::json j;
  j["table"] = name;
  j["description"] = driver.description;
  j["version"] = project_version();
  j["source_revision"] = source_revision();
  j["date_utc"] = utc_now();
  j["seconds"] = seconds;
  j["machine"] = {{"cpu", cpu_model()}, {"hardware_threads", std::thread::hardware_concurrency()}};
  j["settings"] = {{"size", preset.name},
                   {"width", preset.width},
                   {"height", preset.height},
                   {"every", preset.every},
                   {"panorama_height", preset.panorama_height},
                   {"tsdf_voxel_m", preset.tsdf_voxel_m},
                   {"noise", options.noise},
                   {"seed", options.seed},
                   {"threads", options.threads},
                   {"scene_texture", options.texture},
                   {"scenes", options.scenes}};
  j["scans"] = scan_labels(options);
  j["pairs"] = pair_labels(options);
  for (const Claim& c : run.claims)
    j["claims"].push_back({{"table", c.table}, {"better", c.better}, {"worse", c.worse}, {"statement", c.statement}});
  if (run.claims.empty()) j["claims"] = nlohmann::json::array();
  j["driver_settings"] = nlohmann::json::parse(run.settings_json);
  j["tables"] = nlohmann::json::array();  // empty for a recorded refusal
  for (const auto& t : run.tables) {
    nlohmann::json table;
    table["title"] = t.title;
    table["unit"] = t.unit;
    table["lower_is_better"] = t.lower_is_better;
    table["decimals"] = t.decimals;
    table["methods"] = t.methods;  // row and column order ("values" is an object, keyed alphabetically)
    table["columns"] = t.scans;
    for (std::size_t m = 0; m < t.methods.size(); ++m)
      for (std::size_t s = 0; s < t.scans.size(); ++s) {
        const double v = t.get(t.methods[m], t.scans[s]);
        table["values"][t.methods[m]][t.scans[s]] = std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
      }
    j["tables"].push_back(table);
  }
  j["notes"] = run.notes;
  j["failures"] = nlohmann::json::array();
  for (const ColumnFailure& f : run.failures)
    j["failures"].push_back({{"column", f.column}, {"what", f.what}, {"reason", f.reason}});
  {
    std::lock_guard<std::mutex> guard(scans_used_mutex);
    j["scans_rendered_by"] = scans_used;  // cache folder -> source revision that rendered it
  }
  write_file_atomic(dir / (name + ".json"), j.dump(2) + "\n");
  log_info(fmt::format("tables: {} done in {:.0f} s, written to {}", name, seconds, dir.string()));
  return run;
}

}  // namespace panoscan::tables
