// Gate of Table 5 (paper §6.3): integration of the quick-size pair SO-13 (panoramas from
// ground-truth poses, registered with GICP Ours). The paper's ordering (align only > + average >=
// + MAP), the effect of the measured variance in MAP, and ceilings from the measured values.
//
// Measured (quick size, 2 threads): align only 3.023, + average 2.994, + MAP 2.951 mm RMSE (mean
// 1.245 / 1.095 / 1.052 mm); MAP with a constant sigma_z 2.972 mm. Checked to fail with the measured variance replaced
// by a constant (integration_cloud_options with DepthCovarianceModel::kConstant): see the report of issue 7.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "gate_util.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/report.h"
#include "panoscan/eval/statistics.h"
#include "panoscan/tables/tables.h"

using namespace panoscan;

namespace {

// Through run_and_write (what `panoscan tables table5` calls), so that the record is checked too.
tables::TablesOptions table5_options() {
  tables::TablesOptions options = test::gate_options();
  options.out = std::filesystem::path(PANOSCAN_BINARY_DIR) / "gate-records";
  return options;
}

const tables::TableRun& table5_run() {
  static const tables::TableRun run = tables::run_and_write("table5", table5_options());
  return run;
}

constexpr const char* kPair = "SO-13";

}  // namespace

TEST(GateTable5, MapBeatsAverageBeatsAlignOnly) {
  const tables::TableRun& run = table5_run();
  for (const auto& t : run.tables) std::cout << eval::table_to_markdown(t);
  for (const auto& n : run.notes) std::cout << "- " << n << "\n";
  const eval::ResultTable& rmse = run.table("Table 5:");
  const double align = rmse.get("Align only", kPair), average = rmse.get("Align + average", kPair),
               map = rmse.get("Align + MAP", kPair);
  ASSERT_TRUE(std::isfinite(align) && std::isfinite(average) && std::isfinite(map));
  EXPECT_LT(average, align);
  EXPECT_LT(map, align);
  EXPECT_LE(map, average);
}

TEST(GateTable5, MeasuredVarianceBeatsAConstantInMapOverSeeds) {
  // Thinner than the seed spread on one seed (0.024 ± 0.034 mm over seeds 1-2 before issue 17), so
  // gated as a paired statement over seeds 1-3 (seeds 2-3 in memory, about 30 s more): the mean
  // difference is positive and it holds on at least two of the three.
  std::vector<double> map, constant;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    tables::TablesOptions options = test::gate_options();
    options.seed = seed;
    const tables::TableRun run = seed == 1 ? table5_run() : tables::table_driver("table5").run(options);
    map.push_back(run.table("Table 5:").get("Align + MAP", kPair));
    constant.push_back(run.table("Table 5:").get("Align + MAP (constant sigma_z; ablation)", kPair));
  }
  const eval::PairedComparison c = eval::compare_paired(map, constant, true);
  std::cout << "MAP vs constant sigma_z: difference " << c.difference.mean << " mm, holds " << c.holds << " of " << c.n
            << "\n";
  EXPECT_GT(c.difference.mean, 0.0);
  EXPECT_GE(c.holds, 2);
}

TEST(GateTable5, RecordNamesTheCodeThatMadeItAndItsScans) {
  table5_run();
  const std::filesystem::path dir = table5_options().out / "table5";
  for (const char* ext : {".md", ".csv"})
    EXPECT_TRUE(std::filesystem::exists(dir / (std::string("table5") + ext))) << ext;
  std::ifstream in(dir / "table5.json");
  const nlohmann::json record = nlohmann::json::parse(in);
  EXPECT_EQ(record.at("version"), project_version());
  EXPECT_EQ(record.at("source_revision"), source_revision());
  EXPECT_EQ(record.at("settings").at("size"), "quick");
  EXPECT_EQ(record.at("settings").at("noise"), "handa");
  // The pair's two scans, rendered in this ctest run (the gate cache is reset first).
  ASSERT_EQ(record.at("scans_rendered_by").size(), 2u) << record.at("scans_rendered_by").dump();
  for (const auto& [folder, revision] : record.at("scans_rendered_by").items())
    EXPECT_EQ(revision, source_revision()) << folder;
  const double map = record["tables"][0]["values"]["Align + MAP"][kPair].get<double>();
  EXPECT_DOUBLE_EQ(map, table5_run().table("Table 5:").get("Align + MAP", kPair));
}

TEST(GateTable5, Ceilings) {
  const eval::ResultTable& rmse = table5_run().table("Table 5:");
  // Measured: 2.951 mm (MAP), 3.023 mm (align only).
  EXPECT_LT(rmse.get("Align + MAP", kPair), 3.2);
  EXPECT_LT(rmse.get("Align only", kPair), 3.3);
}
