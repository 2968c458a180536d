// Multi-seed statistics of the table drivers: runs per seed, and the merge of run records into
// means with Student-t intervals and paired claims (tables.h: run_seeds_and_write, merge_and_write).
//
// Why Student t over seeds: each seed re-simulates every scan (sensor noise, rotator wobble,
// shutter times) and re-seeds the randomised steps (ORB sampling, RANSAC), so runs with different
// seeds are independent draws of the same experiment; a table cell has one value per seed, and
// its interval is mean ± t_{0.975, n-1} sd / sqrt(n). A claim "A beats B" is tested on the paired
// differences (same scan, same seed), which removes the scan-to-scan and seed-to-seed variation
// that both methods share. The pooled row of a claim takes every (column, seed) as one unit: the
// columns are different scans or rooms, independent given the code, but drawn from a handful of
// scenes, so read it as "over these rooms", not as a population statement.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/log.h"
#include "panoscan/eval/statistics.h"
#include "panoscan/tables/tables.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace panoscan::tables {

namespace {

struct Record {
  std::string origin;  // the file, for errors only (never written: outputs do not depend on paths)
  json content;
  std::uint64_t seed = 0;
  std::string sort_key;
};

// A table run's record: a JSON file of run_and_write (not a merged one).
bool is_run_record(const json& j) { return j.is_object() && j.contains("table") && !j.contains("merged"); }

Record read_record(const fs::path& file) {
  Record r;
  r.origin = file.string();
  r.content = read_json_file(file, "a table run's record (<name>.json of `panoscan tables`)");
  const json& j = r.content;
  if (!is_run_record(j)) throw make_error(r.origin, "table", "is not the record of one table run");
  for (const char* field : {"source_revision", "settings", "tables"})
    if (!j.contains(field)) throw make_error(r.origin, field, "missing");
  const json& s = j["settings"];
  for (const char* field : {"size", "noise", "seed", "scene_texture"})
    if (!s.contains(field)) throw make_error(r.origin, std::string("settings.") + field, "missing");
  if (!s["seed"].is_number_unsigned()) throw make_error(r.origin, "settings.seed", "not a non-negative integer");
  if (!j["tables"].is_array()) throw make_error(r.origin, "tables", "not an array");
  r.seed = s["seed"].get<std::uint64_t>();
  // Records sort by seed, then by their columns: the merge does not depend on the order given.
  r.sort_key = fmt::format("{:020}|{}|{}", r.seed, j.value("scans", json::array()).dump(),
                           j.value("pairs", json::array()).dump());
  return r;
}

// Files and folders -> the run records in them. A folder is searched recursively for
// <name>/<name>.json files that are run records (merged outputs are skipped).
std::vector<Record> collect_records(const std::vector<fs::path>& inputs) {
  std::vector<Record> records;
  for (const fs::path& input : inputs) {
    if (fs::is_regular_file(input)) {
      records.push_back(read_record(input));
    } else if (fs::is_directory(input)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::recursive_directory_iterator(input)) {
        const fs::path& p = entry.path();
        if (!entry.is_regular_file() || p.extension() != ".json") continue;
        if (p.stem() != p.parent_path().filename()) continue;
        found.push_back(p);
      }
      std::sort(found.begin(), found.end());
      int taken = 0;
      for (const fs::path& p : found) {
        const json j = read_json_file(p);
        if (!is_run_record(j)) continue;
        records.push_back(read_record(p));
        ++taken;
      }
      if (taken == 0) throw make_error(input.string(), "", "holds no table run record (<name>/<name>.json)");
    } else {
      throw make_error(input.string(), "", "no such file or folder");
    }
  }
  if (records.empty()) throw make_error("tables merge", "records", "none given");
  std::stable_sort(records.begin(), records.end(),
                   [](const Record& a, const Record& b) { return a.sort_key < b.sort_key; });
  return records;
}

std::string seed_list_text(const std::set<std::uint64_t>& seeds) {
  // 1,2,3,5 -> "1-3, 5"
  std::string text;
  auto it = seeds.begin();
  while (it != seeds.end()) {
    std::uint64_t first = *it, last = *it;
    for (++it; it != seeds.end() && *it == last + 1; ++it) last = *it;
    if (!text.empty()) text += ", ";
    text += first == last ? fmt::format("{}", first) : fmt::format("{}-{}", first, last);
  }
  return text;
}

// One merged table: cells[method][column][seed].
struct MergedTable {
  std::string title, unit;
  bool lower_is_better = true;
  int decimals = 3;
  std::vector<std::string> methods, columns;
  std::map<std::string, std::map<std::string, std::map<std::uint64_t, double>>> cells;
  std::map<std::string, std::map<std::string, int>> missing;  // runs that did not measure a cell
};

void add_unique(std::vector<std::string>& list, const std::string& item) {
  if (std::find(list.begin(), list.end(), item) == list.end()) list.push_back(item);
}

struct Group {
  std::string name, noise;
  std::vector<const Record*> records;
  std::vector<MergedTable> tables;
  std::vector<Claim> claims;
  std::set<std::uint64_t> seeds;
  // (column, what) -> seed -> reason: the runs whose stage failed or refused (TableRun::failures).
  std::map<std::pair<std::string, std::string>, std::map<std::uint64_t, std::string>> failures;
};

void check_same(const Group& group, const Record& r, const std::string& field, const json& value,
                const json& first) {
  if (value != first)
    throw make_error(r.origin, field,
                     fmt::format("{} differs from {}'s {} ({} against {}): runs of one merge must share it", field,
                                 group.records.front()->origin, field, value.dump(), first.dump()));
}

void fill_group(Group& g) {
  const Record& first = *g.records.front();
  std::map<std::string, std::map<std::string, std::map<std::string, std::map<std::uint64_t, std::string>>>> origin;
  for (const Record* r : g.records) {
    const json& s = r->content["settings"];
    check_same(g, *r, "settings.size", s["size"], first.content["settings"]["size"]);
    check_same(g, *r, "settings.scene_texture", s["scene_texture"], first.content["settings"]["scene_texture"]);
    check_same(g, *r, "source_revision", r->content["source_revision"], first.content["source_revision"]);
    g.seeds.insert(r->seed);
    for (const json& t : r->content["tables"]) {
      if (!t.is_object() || !t.contains("title") || !t["title"].is_string())
        throw make_error(r->origin, "tables[].title", "missing or not a string");
      const std::string title = t["title"];
      auto it = std::find_if(g.tables.begin(), g.tables.end(), [&](const MergedTable& m) { return m.title == title; });
      if (it == g.tables.end()) {
        MergedTable m;
        m.title = title;
        m.unit = t.value("unit", "");
        m.lower_is_better = t.value("lower_is_better", true);
        m.decimals = t.value("decimals", 3);
        g.tables.push_back(m);
        it = g.tables.end() - 1;
      }
      // Rows and columns in the drivers' order where the record gives it (older records: by name).
      for (const char* order : {"methods", "columns"})
        if (t.contains(order)) {
          if (!t[order].is_array()) throw make_error(r->origin, std::string("tables[].") + order, "not an array");
          for (const json& name : t[order]) {
            if (!name.is_string())
              throw make_error(r->origin, std::string("tables[].") + order, "holds a non-string");
            add_unique(std::string(order) == "methods" ? it->methods : it->columns, name.get<std::string>());
          }
        }
      if (!t.contains("values")) continue;
      if (!t["values"].is_object()) throw make_error(r->origin, "tables[].values", "not an object");
      for (const auto& [method, row] : t["values"].items()) {
        if (!row.is_object()) throw make_error(r->origin, "tables[].values." + method, "not an object");
        add_unique(it->methods, method);
        for (const auto& [column, value] : row.items()) {
          add_unique(it->columns, column);
          if (value.is_null()) {
            ++it->missing[method][column];
            continue;
          }
          if (!value.is_number())
            throw make_error(r->origin, fmt::format("tables[{}].values.{}.{}", title, method, column),
                             "not a number or null");
          const double v = value.get<double>();
          auto& cell = it->cells[method][column];
          auto& from = origin[title][method][column];
          if (cell.count(r->seed) && cell[r->seed] != v)
            throw make_error(r->origin, fmt::format("tables[{}].values.{}.{}", title, method, column),
                             fmt::format("seed {} has {} here and {} in {}", r->seed, v, cell[r->seed],
                                         from[r->seed]));
          cell[r->seed] = v;
          from[r->seed] = r->origin;
        }
      }
    }
    if (r->content.contains("failures")) {
      if (!r->content["failures"].is_array()) throw make_error(r->origin, "failures", "not an array");
      for (const json& f : r->content["failures"]) {
        if (!f.is_object() || !f.contains("column") || !f["column"].is_string() || !f.contains("what") ||
            !f["what"].is_string())
          throw make_error(r->origin, "failures[]", "needs the strings column and what");
        g.failures[{f["column"].get<std::string>(), f["what"].get<std::string>()}][r->seed] =
            f.value("reason", std::string());
      }
    }
    if (r->content.contains("claims") && r->content["claims"].is_array())
      for (const json& c : r->content["claims"]) {
        Claim claim{c.value("table", ""), c.value("better", ""), c.value("worse", ""), c.value("statement", "")};
        const bool known = std::any_of(g.claims.begin(), g.claims.end(), [&](const Claim& k) {
          return k.table == claim.table && k.better == claim.better && k.worse == claim.worse;
        });
        if (!known) g.claims.push_back(claim);
      }
  }
}

std::string format_value(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  return fmt::format("{:.{}f}", v, decimals);
}

std::string format_summary(const eval::SampleSummary& s, int decimals) {
  if (s.n == 0) return "-";
  if (s.n == 1) return fmt::format("{} (1)", format_value(s.mean, decimals));
  return fmt::format("{} ± {} ({})", format_value(s.mean, decimals), format_value(s.half_width(), decimals), s.n);
}

json summary_json(const eval::SampleSummary& s) {
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(); };
  return {{"n", s.n}, {"mean", num(s.mean)}, {"sd", num(s.sd)}, {"ci95_low", num(s.ci_low)},
          {"ci95_high", num(s.ci_high)}};
}

struct ClaimResult {
  const Claim* claim;
  std::string column;  // or "all columns"
  eval::PairedComparison comparison;
  int decimals = 3;
  std::string unit;
};

std::vector<ClaimResult> evaluate_claims(const Group& g) {
  std::vector<ClaimResult> results;
  for (const Claim& claim : g.claims) {
    const auto table = std::find_if(g.tables.begin(), g.tables.end(),
                                    [&](const MergedTable& t) { return t.title.rfind(claim.table, 0) == 0; });
    if (table == g.tables.end() || !table->cells.count(claim.better) || !table->cells.count(claim.worse)) continue;
    std::vector<double> all_better, all_worse;
    int columns_measured = 0;
    for (const std::string& column : table->columns) {
      const auto& a = table->cells.at(claim.better);
      const auto& b = table->cells.at(claim.worse);
      if (!a.count(column) || !b.count(column)) continue;
      std::vector<double> better, worse;
      for (const auto& [seed, v] : a.at(column))
        if (b.at(column).count(seed)) {
          better.push_back(v);
          worse.push_back(b.at(column).at(seed));
        }
      if (better.empty()) continue;
      ++columns_measured;
      all_better.insert(all_better.end(), better.begin(), better.end());
      all_worse.insert(all_worse.end(), worse.begin(), worse.end());
      results.push_back(
          {&claim, column, eval::compare_paired(better, worse, table->lower_is_better), table->decimals, table->unit});
    }
    if (columns_measured >= 2)
      results.push_back({&claim, "all columns", eval::compare_paired(all_better, all_worse, table->lower_is_better),
                         table->decimals, table->unit});
  }
  return results;
}

std::string claims_markdown(const std::vector<ClaimResult>& results, const std::string& first_column) {
  std::string md = fmt::format(
      "| {}Claim (A beats B) | column | mean difference B - A ± 95% CI | holds | verdict |\n|{}---|---|---|---|---|\n",
      first_column.empty() ? "" : first_column + " | ", first_column.empty() ? "" : "---|");
  for (const ClaimResult& r : results) {
    const auto& d = r.comparison.difference;
    md += fmt::format("| {}{}: {} beats {} | {} | {} {} | {} of {} | {} |\n", first_column.empty() ? "" : "",
                      r.claim->statement, r.claim->better, r.claim->worse, r.column,
                      d.n >= 2 ? fmt::format("{} ± {}", format_value(d.mean, r.decimals + 1),
                                             format_value(d.half_width(), r.decimals + 1))
                               : format_value(d.mean, r.decimals + 1),
                      r.unit, r.comparison.holds, r.comparison.n, r.comparison.verdict);
  }
  return md;
}

const char* kMethodNote =
    "Each cell: mean ± half-width of the 95% Student-t interval (n - 1 degrees of freedom) over the seeds, and n, the "
    "runs that measured it; each seed re-simulates the scans (noise, wobble, shutter times) and re-seeds ORB and "
    "RANSAC, so runs are independent. A claim is tested on the paired differences (same column, same seed), oriented "
    "so that a positive difference means the claim holds: 'holds' when the whole interval is above 0, 'reversed' when "
    "below, 'within noise' otherwise. The 'all columns' row pools every (column, seed) pair as one unit.";

struct Written {
  fs::path dir;
  std::vector<ClaimResult> claims;
  std::size_t failed_runs = 0;  // (column, what, seed) entries of Group::failures
};

// Writes one group's merged record into `dir` (<name>.md, <name>.csv, <name>_claims.csv, <name>.json).
Written write_group(const Group& g, const fs::path& dir) {
  const json& first = g.records.front()->content;
  const std::string seeds = seed_list_text(g.seeds);
  Written written{dir, evaluate_claims(g)};
  for (const auto& entry : g.failures) written.failed_runs += entry.second.size();
  std::string md = fmt::format("# {} ({} noise, {} size, scene texture {}): {} seeds ({})\n\n", g.name, g.noise,
                               first["settings"]["size"].get<std::string>(),
                               first["settings"]["scene_texture"].get<std::string>(), g.seeds.size(), seeds);
  std::string csv = "table,unit,method,column,n,mean,sd,ci95_low,ci95_high,missing\n";
  json j;
  j["merged"] = true;
  j["table"] = g.name;
  j["noise"] = g.noise;
  j["size"] = first["settings"]["size"];
  j["scene_texture"] = first["settings"]["scene_texture"];
  j["source_revision"] = first["source_revision"];
  j["seeds"] = std::vector<std::uint64_t>(g.seeds.begin(), g.seeds.end());
  j["statistics"] = kMethodNote;
  for (const Record* r : g.records)
    j["runs"].push_back({{"seed", r->seed},
                         {"scans", r->content.value("scans", json::array())},
                         {"pairs", r->content.value("pairs", json::array())},
                         {"notes", r->content.value("notes", json::array())}});
  for (const MergedTable& t : g.tables) {
    md += fmt::format("{} ({}; mean ± 95% CI (n))\n\n| Method |", t.title, t.unit);
    for (const auto& c : t.columns) md += " " + c + " |";
    md += "\n|---|";
    for (std::size_t c = 0; c < t.columns.size(); ++c) md += "---|";
    md += "\n";
    json table = {{"title", t.title}, {"unit", t.unit}, {"lower_is_better", t.lower_is_better}};
    for (const std::string& method : t.methods) {
      md += "| " + method + " |";
      for (const std::string& column : t.columns) {
        std::vector<double> values;
        json per_seed = json::object();
        if (t.cells.count(method) && t.cells.at(method).count(column))
          for (const auto& [seed, v] : t.cells.at(method).at(column)) {
            values.push_back(v);
            per_seed[std::to_string(seed)] = v;
          }
        const eval::SampleSummary s = eval::summarize_sample(values);
        int missing = 0;
        if (t.missing.count(method) && t.missing.at(method).count(column)) missing = t.missing.at(method).at(column);
        md += " " + format_summary(s, t.decimals) + " |";
        auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.9g}", v) : std::string(); };
        csv += fmt::format("\"{}\",{},\"{}\",{},{},{},{},{},{},{}\n", t.title, t.unit, method, column, s.n,
                           num(s.mean), num(s.sd), num(s.ci_low), num(s.ci_high), missing);
        json cell = summary_json(s);
        cell["values"] = per_seed;
        cell["missing"] = missing;
        table["cells"][method][column] = cell;
      }
      md += "\n";
    }
    md += "\n";
    j["tables"].push_back(table);
  }
  // The runs that gave no value: a cell's n counts only the runs that measured it, so a method that
  // fails on some seeds must be read together with how often it failed.
  j["failures"] = json::array();
  if (!g.failures.empty()) {
    md += "Runs that gave no value (a stage failed or refused; not in the cells' n):\n\n"
          "| column | what | seeds | runs | first reason |\n|---|---|---|---|---|\n";
    for (const auto& [key, by_seed] : g.failures) {
      std::set<std::uint64_t> seeds_failed;
      json reasons = json::object();
      for (const auto& [seed, reason] : by_seed) {
        seeds_failed.insert(seed);
        reasons[std::to_string(seed)] = reason;
      }
      md += fmt::format("| {} | {} | {} | {} of {} | {} |\n", key.first, key.second, seed_list_text(seeds_failed),
                        by_seed.size(), g.seeds.size(), by_seed.begin()->second);
      j["failures"].push_back({{"column", key.first},
                               {"what", key.second},
                               {"runs", by_seed.size()},
                               {"of", g.seeds.size()},
                               {"reasons", reasons}});
    }
    md += "\n";
  }
  std::string claims_csv = "claim,better,worse,column,n,holds,mean_difference,ci95_low,ci95_high,verdict\n";
  j["claims"] = json::array();
  if (!written.claims.empty()) {
    md += "Claims of the paper tested by this table (paired over seeds):\n\n" + claims_markdown(written.claims, "") +
          "\n";
    for (const ClaimResult& r : written.claims) {
      const auto& d = r.comparison.difference;
      auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.9g}", v) : std::string(); };
      claims_csv += fmt::format("\"{}\",\"{}\",\"{}\",{},{},{},{},{},{},{}\n", r.claim->statement, r.claim->better,
                                r.claim->worse, r.column, r.comparison.n, r.comparison.holds, num(d.mean),
                                num(d.ci_low), num(d.ci_high), r.comparison.verdict);
      json c = {{"statement", r.claim->statement}, {"table", r.claim->table},  {"better", r.claim->better},
                {"worse", r.claim->worse},         {"column", r.column},       {"holds", r.comparison.holds},
                {"n", r.comparison.n},             {"verdict", r.comparison.verdict}};
      c["difference"] = summary_json(d);
      j["claims"].push_back(c);
    }
  }
  md += std::string("Notes:\n- ") + kMethodNote + "\n- Source revision " +
        first["source_revision"].get<std::string>() + "; the runs' own notes are in " + g.name + ".json (runs[]).\n";
  fs::create_directories(dir);
  write_file_atomic(dir / (g.name + ".md"), md);
  write_file_atomic(dir / (g.name + ".csv"), csv);
  write_file_atomic(dir / (g.name + "_claims.csv"), claims_csv);
  write_file_atomic(dir / (g.name + ".json"), j.dump(2) + "\n");
  return written;
}

std::vector<Group> make_groups(const std::vector<Record>& records) {
  std::vector<Group> groups;
  for (const Record& r : records) {
    const std::string name = r.content["table"].is_string() ? r.content["table"].get<std::string>() : "";
    if (name.empty()) throw make_error(r.origin, "table", "not a table name");
    const std::string noise = r.content["settings"]["noise"].is_string()
                                  ? r.content["settings"]["noise"].get<std::string>()
                                  : throw make_error(r.origin, "settings.noise", "not a string");
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const Group& g) { return g.name == name && g.noise == noise; });
    if (it == groups.end()) {
      groups.push_back({name, noise, {}, {}, {}, {}});
      it = groups.end() - 1;
    }
    it->records.push_back(&r);
  }
  // Tables in the drivers' order, then noise presets by name: independent of the input order.
  auto rank = [](const std::string& name) {
    const auto& drivers = table_drivers();
    for (std::size_t i = 0; i < drivers.size(); ++i)
      if (drivers[i].name == name) return int(i);
    return int(drivers.size());
  };
  std::stable_sort(groups.begin(), groups.end(), [&](const Group& a, const Group& b) {
    return std::make_pair(rank(a.name), a.noise) < std::make_pair(rank(b.name), b.noise);
  });
  for (Group& g : groups) fill_group(g);
  return groups;
}

}  // namespace

std::vector<fs::path> merge_and_write(const std::vector<fs::path>& inputs, const fs::path& out) {
  const std::vector<Record> records = collect_records(inputs);
  const std::vector<Group> groups = make_groups(records);
  std::vector<fs::path> dirs;
  std::string claims = "# Claims of the paper over seeds\n\n";
  for (const Group& g : groups) {
    const Written w = write_group(g, out / g.noise / g.name);
    dirs.push_back(w.dir);
    if (w.claims.empty() && w.failed_runs == 0) continue;
    claims += fmt::format("## {} ({} noise, seeds {})\n\n", g.name, g.noise, seed_list_text(g.seeds));
    if (!w.claims.empty()) claims += claims_markdown(w.claims, "") + "\n";
    if (w.failed_runs > 0)
      claims += fmt::format("Runs without a value: {} (a stage failed or refused; which, in {}/{}/{}.md).\n\n",
                            w.failed_runs, g.noise, g.name, g.name);
  }
  claims += std::string("Notes:\n- ") + kMethodNote + "\n";
  write_file_atomic(out / "claims.md", claims);
  log_info(fmt::format("tables merge: {} runs into {} tables under {}", records.size(), groups.size(), out.string()));
  return dirs;
}

void run_seeds_and_write(const std::string& name, const TablesOptions& options, const std::vector<std::uint64_t>& seeds) {
  if (seeds.empty()) throw make_error("--seeds", "", "names no seed");
  if (seeds.size() == 1) {
    TablesOptions one = options;
    one.seed = seeds.front();
    run_and_write(name, one);
    return;
  }
  const fs::path runs = options.out / name / "runs";
  for (std::uint64_t seed : seeds) {
    TablesOptions one = options;
    one.seed = seed;
    one.out = runs / fmt::format("seed{}", seed);
    if (one.cache.empty()) one.cache = options.out / "scans";
    run_and_write(name, one);
  }
  const std::vector<Record> records = collect_records({runs});
  const std::vector<Group> groups = make_groups(records);
  for (const Group& g : groups) write_group(g, options.out / g.name);
}

std::vector<std::uint64_t> parse_seed_list(const std::string& text) {
  std::set<std::uint64_t> seeds;
  std::size_t start = 0;
  auto number = [&](const std::string& part) {
    if (part.empty() || part.find_first_not_of("0123456789") != std::string::npos || part.size() > 18)
      throw make_error("--seeds", text, "expected seeds like 3, 1-8 or 1,3,5-7");
    return std::stoull(part);
  };
  while (start <= text.size()) {
    const auto comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const auto dash = item.find('-');
    if (dash == std::string::npos) {
      seeds.insert(number(item));
    } else {
      const std::uint64_t first = number(item.substr(0, dash)), last = number(item.substr(dash + 1));
      if (last < first || last - first > 9999) throw make_error("--seeds", text, "a range must ascend, at most 10000");
      for (std::uint64_t s = first; s <= last; ++s) seeds.insert(s);
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return {seeds.begin(), seeds.end()};
}

}  // namespace panoscan::tables
