// Gate of Table 3 (paper §6.2): on each quick-size scan (SO-1, SL-1; ground-truth poses) the
// Eq. 5 solvers with a smoothness term (TV-L1, TSA-L1) beat averaging in the panorama ("ERP Ave."),
// and the TSDF volume and ray-cast surfels, and every row stays under a ceiling set from the measured values with a
// margin. Checked to fail with the smoothness term switched off (lambda_b = 0: the L1 solutions become the per-pixel
// medians, SO-1 4.44 mm and SL-1 4.13 mm, above the TV/TSA ceilings, and the ratio check fails).
// The ordering check alone would not notice that: the medians beat averaging too.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "gate_util.h"
#include "panoscan/eval/report.h"
#include "panoscan/tables/tables.h"

using namespace panoscan;

namespace {

const tables::TableRun& table3_run() {
  static const tables::TableRun run = tables::table_driver("table3").run(test::gate_options());
  return run;
}

}  // namespace

TEST(GateTable3, SmoothnessBeatsAveraging) {
  const tables::TableRun& run = table3_run();
  const eval::ResultTable& t = run.table("Table 3:");
  std::cout << eval::table_to_markdown(t) << eval::table_to_markdown(run.table("Table 3c")) << std::endl;
  for (const std::string& scan : t.scans) {
    const double ave = t.get("ERP Ave.", scan);
    ASSERT_TRUE(std::isfinite(ave)) << scan;
    // The paper: every optimisation beats averaging (SO-1: 5.596 / 5.515 vs 6.778 mm).
    EXPECT_LT(t.get("ERP TV-L1", scan), ave) << scan;
    EXPECT_LT(t.get("ERP TSA-L1", scan), ave) << scan;
    EXPECT_LT(t.get("ERP TP-L1", scan), ave) << scan;
    // ... and the TSDF volume and the ray-cast surfels (SO-1: 5.515 vs 15.54 and 6.922 mm).
    for (const char* baseline : {"TSDF Vol.", "Surfels-4m (RC)"}) {
      ASSERT_TRUE(std::isfinite(t.get(baseline, scan))) << baseline << " " << scan;
      EXPECT_LT(t.get("ERP TSA-L1", scan), t.get(baseline, scan)) << baseline << " " << scan;
      EXPECT_LT(t.get("ERP TV-L1", scan), t.get(baseline, scan)) << baseline << " " << scan;
    }
  }
}

TEST(GateTable3, Ceilings) {
  const eval::ResultTable& t = table3_run().table("Table 3:");
  // Ceilings (mm): measured at the quick size (see the comment per row) plus a margin.
  struct Ceiling {
    const char* row;
    const char* scan;
    double mm;
  };
  for (const Ceiling& c : std::initializer_list<Ceiling>{
           // Measured 2026-11-24 (quick, 2 threads): SO-1 / SL-1.
           {"ERP Ave.", "SO-1", 19.0},           // 16.95
           {"ERP Ave.", "SL-1", 10.0},           // 8.59
           {"ERP TV-L1", "SO-1", 3.9},           // 3.20
           {"ERP TV-L1", "SL-1", 3.8},           // 3.09
           {"ERP TSA-L1", "SO-1", 4.2},          // 3.48
           {"ERP TSA-L1", "SL-1", 4.0},          // 3.33
           {"ERP TP-L1", "SO-1", 5.7},           // 4.69
           {"ERP TP-L1", "SL-1", 5.5},           // 4.55
           {"ERP TV-L1 (radial)", "SO-1", 3.9},  // 3.22
           {"ERP TV-L1 (radial)", "SL-1", 3.8},  // 3.09
       }) {
    const double value = t.get(c.row, c.scan);
    EXPECT_TRUE(std::isfinite(value)) << c.row << " " << c.scan;
    EXPECT_LT(value, c.mm) << c.row << " " << c.scan;
  }
  // The paper's guidance for lambda_b: data about 4x the weighted smoothness at the solution; the
  // default mapping lands within a factor of 3 of it (README, "lambda_b").
  const eval::ResultTable& ratio = table3_run().table("Table 3c");
  for (const std::string& scan : ratio.scans)
    for (const char* row : {"ERP TV-L1", "ERP TSA-L1", "ERP TP-L1"}) {
      const double r = ratio.get(row, scan);
      EXPECT_GT(r, 4.0 / 3.0) << row << " " << scan;
      EXPECT_LT(r, 4.0 * 3.0) << row << " " << scan;
    }
}
