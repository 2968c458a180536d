// `tables merge` on hand-written run records: the cell statistics (mean, Student-t interval, n),
// the paired claims, independence of the input order, and the errors for records that must not
// be merged (conflicting cells, other source revisions, not a run record).
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "panoscan/tables/tables.h"
#include "test_util.h"

namespace panoscan::tables {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testutil::error_of;
using testutil::TempDir;

// A table5-like record of one seed: "Ours" and "Baseline" on columns SO-13 (and SL-12 when given).
json record(std::uint64_t seed, double ours, double baseline, const std::string& revision = "abc123",
            double ours_sl = NAN, double baseline_sl = NAN) {
  json values;
  values["Ours"]["SO-13"] = ours;
  values["Baseline"]["SO-13"] = baseline;
  std::vector<std::string> columns = {"SO-13"};
  if (std::isfinite(ours_sl)) {
    values["Ours"]["SL-12"] = ours_sl;
    values["Baseline"]["SL-12"] = baseline_sl;
    columns.push_back("SL-12");
  }
  return {{"table", "table5"},
          {"source_revision", revision},
          {"settings", {{"size", "quick"}, {"noise", "handa"}, {"seed", seed}, {"scene_texture", "icl"}}},
          {"pairs", columns},
          {"scans", json::array()},
          {"claims", {{{"table", "Table 5:"}, {"better", "Ours"}, {"worse", "Baseline"}, {"statement", "ours wins"}}}},
          {"tables",
           {{{"title", "Table 5: RMSE"},
             {"unit", "mm"},
             {"lower_is_better", true},
             {"decimals", 3},
             {"methods", {"Ours", "Baseline"}},
             {"columns", columns},
             {"values", values}}}}};
}

fs::path write_record(const fs::path& dir, const json& j) {
  fs::create_directories(dir / "table5");
  const fs::path file = dir / "table5" / "table5.json";
  std::ofstream(file) << j.dump(2);
  return file;
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(TablesMerge, CellsGetMeanIntervalAndCountAndClaimsTheirPairedDifference) {
  TempDir tmp("merge-stats");
  // Ours 1, 2, 3 against Baseline 2, 3.5, 4: differences 1, 1.5, 1 (mean 7/6, sd 0.2887).
  write_record(tmp / "s1", record(1, 1.0, 2.0));
  write_record(tmp / "s2", record(2, 2.0, 3.5));
  write_record(tmp / "s3", record(3, 3.0, 4.0));
  merge_and_write({tmp / "s1", tmp / "s2", tmp / "s3"}, tmp / "out");
  const std::string md = read_text(tmp / "out" / "handa" / "table5" / "table5.md");
  // Mean 2, sd 1, t(0.975, 2) = 4.3027: half-width 4.3027 / sqrt(3) = 2.484.
  EXPECT_NE(md.find("| Ours | 2.000 ± 2.484 (3) |"), std::string::npos) << md;
  EXPECT_NE(md.find("3 seeds (1-3)"), std::string::npos) << md;
  // Rows keep the record's order (Ours before Baseline), not the alphabetical one.
  EXPECT_LT(md.find("| Ours |"), md.find("| Baseline |"));
  const json merged = json::parse(read_text(tmp / "out" / "handa" / "table5" / "table5.json"));
  ASSERT_TRUE(merged["claims"].is_array());
  ASSERT_EQ(merged["claims"].size(), 1u);  // one column: no pooled row
  const json& claim = merged["claims"][0];
  EXPECT_EQ(claim["verdict"], "holds");
  EXPECT_EQ(claim["holds"], 3);
  EXPECT_NEAR(claim["difference"]["mean"].get<double>(), 7.0 / 6.0, 1e-12);
  const double half = 4.30265273 * std::sqrt(1.0 / 12.0) / std::sqrt(3.0);
  EXPECT_NEAR(claim["difference"]["ci95_low"].get<double>(), 7.0 / 6.0 - half, 1e-6);
  EXPECT_TRUE(fs::exists(tmp / "out" / "claims.md"));
}

TEST(TablesMerge, AReversedClaimAndAPooledRowOverColumns) {
  TempDir tmp("merge-reversed");
  write_record(tmp / "s1", record(1, 2.0, 1.0, "abc123", 5.0, 4.0));
  write_record(tmp / "s2", record(2, 2.2, 1.1, "abc123", 5.1, 4.0));
  merge_and_write({tmp.path()}, tmp / "out");
  const json merged = json::parse(read_text(tmp / "out" / "handa" / "table5" / "table5.json"));
  ASSERT_EQ(merged["claims"].size(), 3u);  // SO-13, SL-12, all columns
  for (const json& c : merged["claims"]) {
    EXPECT_EQ(c["holds"], 0);
    EXPECT_EQ(c["verdict"], "reversed") << c.dump();
  }
  EXPECT_EQ(merged["claims"][2]["column"], "all columns");
  EXPECT_EQ(merged["claims"][2]["n"], 4);
}

TEST(TablesMerge, TheOutputDoesNotDependOnTheInputsOrderOrPaths) {
  TempDir tmp("merge-order");
  const fs::path a = write_record(tmp / "x" / "seed1", record(1, 1.0, 2.0));
  const fs::path b = write_record(tmp / "y" / "other", record(2, 1.5, 2.5));
  const fs::path c = write_record(tmp / "z", record(3, 1.2, 2.1));
  merge_and_write({a, b, c}, tmp / "one");
  merge_and_write({c, tmp / "y", a}, tmp / "two");
  for (const char* file : {"table5.md", "table5.csv", "table5.json", "table5_claims.csv"})
    EXPECT_EQ(read_text(tmp / "one" / "handa" / "table5" / file), read_text(tmp / "two" / "handa" / "table5" / file))
        << file;
  EXPECT_EQ(read_text(tmp / "one" / "claims.md"), read_text(tmp / "two" / "claims.md"));
  // The same record twice is one run, not two.
  merge_and_write({a, a, b, c}, tmp / "three");
  EXPECT_EQ(read_text(tmp / "one" / "handa" / "table5" / "table5.md"),
            read_text(tmp / "three" / "handa" / "table5" / "table5.md"));
}

TEST(TablesMerge, RefusesRecordsThatMustNotBeMerged) {
  TempDir tmp("merge-errors");
  const fs::path a = write_record(tmp / "a", record(1, 1.0, 2.0));
  const fs::path conflict = write_record(tmp / "b", record(1, 1.1, 2.0));
  std::string message = error_of([&] { merge_and_write({a, conflict}, tmp / "out"); });
  EXPECT_NE(message.find("seed 1"), std::string::npos) << message;
  EXPECT_NE(message.find(a.string()), std::string::npos) << message;
  EXPECT_NE(message.find(conflict.string()), std::string::npos) << message;

  const fs::path other = write_record(tmp / "c", record(2, 1.0, 2.0, "def456"));
  message = error_of([&] { merge_and_write({a, other}, tmp / "out"); });
  EXPECT_NE(message.find("source_revision"), std::string::npos) << message;

  fs::create_directories(tmp / "d" / "x");
  std::ofstream(tmp / "d" / "x" / "x.json") << R"({"something": 1})";
  message = error_of([&] { merge_and_write({tmp / "d" / "x" / "x.json"}, tmp / "out"); });
  EXPECT_NE(message.find("x.json"), std::string::npos) << message;
  message = error_of([&] { merge_and_write({tmp / "missing"}, tmp / "out"); });
  EXPECT_NE(message.find("missing"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(tmp / "out" / "claims.md"));
}

TEST(TablesMerge, FailedRunsAreCountedBesideTheCellsNotAveragedIntoThem) {
  TempDir tmp("merge-failures");
  write_record(tmp / "s1", record(1, 1.0, 2.0));
  write_record(tmp / "s2", record(2, 2.0, 3.0));
  // Seed 3 refused (tables --record-refusals): no cells, one failure.
  json refused = record(3, 0.0, 0.0);
  refused["tables"] = json::array();
  refused["failures"] = {{{"column", "SO-13"}, {"what", "refused"}, {"reason", "SO-1: tracking: not trustworthy"}}};
  write_record(tmp / "s3", refused);
  // Seed 4 measured the baseline only; Ours failed.
  json partial = record(4, 5.0, 4.0);
  partial["tables"][0]["values"]["Ours"].erase("SO-13");
  partial["failures"] = {{{"column", "SO-13"}, {"what", "Ours failed"}, {"reason", "no convergence"}}};
  write_record(tmp / "s4", partial);
  merge_and_write({tmp.path()}, tmp / "out");
  const std::string md = read_text(tmp / "out" / "handa" / "table5" / "table5.md");
  EXPECT_NE(md.find("| Ours | 1.500 ± 6.353 (2) |"), std::string::npos) << md;  // seeds 1-2 only
  EXPECT_NE(md.find("| SO-13 | refused | 3 | 1 of 4 | SO-1: tracking: not trustworthy |"), std::string::npos) << md;
  EXPECT_NE(md.find("| SO-13 | Ours failed | 4 | 1 of 4 | no convergence |"), std::string::npos) << md;
  const json merged = json::parse(read_text(tmp / "out" / "handa" / "table5" / "table5.json"));
  ASSERT_EQ(merged["failures"].size(), 2u);
  EXPECT_EQ(merged["failures"][0]["runs"], 1);
  EXPECT_EQ(merged["failures"][0]["of"], 4);
  EXPECT_NE(read_text(tmp / "out" / "claims.md").find("Runs without a value: 2"), std::string::npos);
  // A malformed failures entry names the record and the field.
  json bad = record(5, 1.0, 2.0);
  bad["failures"] = {{{"column", 3}}};
  const fs::path bad_file = write_record(tmp / "bad", bad);
  const std::string message = error_of([&] { merge_and_write({bad_file}, tmp / "out2"); });
  EXPECT_NE(message.find("failures[]"), std::string::npos) << message;
  EXPECT_NE(message.find(bad_file.string()), std::string::npos) << message;
}

TEST(TablesMerge, SeedListsParse) {
  EXPECT_EQ(parse_seed_list("3"), (std::vector<std::uint64_t>{3}));
  EXPECT_EQ(parse_seed_list("1-4"), (std::vector<std::uint64_t>{1, 2, 3, 4}));
  EXPECT_EQ(parse_seed_list("5,1,3-4,3"), (std::vector<std::uint64_t>{1, 3, 4, 5}));
  for (const char* bad : {"", "a", "4-2", "1,,2", "-3", "1-"})
    EXPECT_NE(error_of([&] { parse_seed_list(bad); }).find("--seeds"), std::string::npos) << bad;
}

TEST(TablesMerge, ColumnsNameTheirScans) {
  TablesOptions options;
  options.only = {"SO-13", "SO-2"};
  const std::vector<Column> pairs = table_driver("table4").columns(options);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].label, "SO-13");
  EXPECT_EQ(pairs[0].scans, (std::vector<std::string>{"SO-1", "SO-3"}));
  const std::vector<Column> scans = table_driver("table2").columns(options);
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].label, "SO-2");
  options.only.clear();
  options.scenes = {"generated:2"};
  const std::vector<Column> generated = table_driver("table5").columns(options);
  ASSERT_EQ(generated.size(), 2u);
  EXPECT_EQ(generated[1].label, "GL2-12");
  EXPECT_EQ(generated[1].scans, (std::vector<std::string>{"GL2-1", "GL2-2"}));
}

}  // namespace
}  // namespace panoscan::tables
