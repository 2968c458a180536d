// Gate of the paper's Table 2 (tracking with a single camera) at the quick size on both scans of
// the preset (office SO-1 and living room SL-1): the factor graph (Eq. 1-3) beats bundle
// adjustment alone by a clear margin on the stitched ground-truth depth and on the ATE; with the
// middle camera alone the whole panorama is worse than with the three-camera rig, and the rig
// tracks even the middle camera better (the shared wobble of tracking.h); absolute
// ceilings on the stitched RMSE, the ATE and the rotation axis; and the depth odometry (beyond the
// paper) improves on the graph of Eq. 1-3.
// Scans at the default ICL-NUIM texture density (plain painted walls and ceilings).
// Ceilings: the measured value (quick size, Handa noise, seed 1, 2 threads) plus a margin.
// Checked to fail, at the ICL density: with Eq. 2 off ("Ours" is then bundle adjustment); with
// Eq. 3 off (the whole rig: stitched 21.76 / 10.13 mm against 5.06 / 6.90); with the shared wobble
// off (rig ATE 5.98 / 4.67 mm, no better than one camera's 5.97 / 4.65; whole rig 8.51 / 12.22 mm).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "gate_util.h"
#include "panoscan/eval/report.h"
#include "panoscan/tables/tables.h"

using namespace panoscan;

TEST(GateTable2, FactorGraphBeatsBundleAdjustmentAndTheRigBeatsOneCamera) {
  tables::TablesOptions options = test::gate_options("handa");
  const tables::TableRun run = tables::table_driver("table2").run(options);
  const eval::ResultTable& stitched = run.table("Table 2:");
  const eval::ResultTable& ate = run.table("Table 2 (ATE)");
  const eval::ResultTable& axis = run.table("Table 2 (axis)");
  for (const auto* table : {&stitched, &ate, &axis}) std::cout << eval::table_to_markdown(*table) << "\n";
  for (const auto& note : run.notes) std::cout << "- " << note << "\n";

  const std::string ba = "Ours (BA only)", ours = "Ours", rig = "Ours, three cameras (middle camera evaluated)";
  const std::string rig_all = "Ours, three cameras (all cameras evaluated)";
  const std::string ours_all = "Ours, middle camera tracked (all cameras evaluated; the others follow Eq. 2's model)";
  ASSERT_FALSE(stitched.scans.empty());
  double ratio_sum = 0.0;
  for (const std::string& scan : stitched.scans) {
    SCOPED_TRACE(scan);
    for (const auto& row : {ba, ours, rig, rig_all, ours_all})
      ASSERT_TRUE(std::isfinite(stitched.get(row, scan))) << row;
    // The paper's claim: Eq. 2-3 carry the frames that see plain walls (measured SO-1 / SL-1:
    // stitched 3.69 vs 7.11, 2.19 vs 5.48 mm; ATE 5.97 vs 15.59, 4.65 vs 16.64 mm).
    EXPECT_LT(stitched.get(ours, scan), 0.75 * stitched.get(ba, scan));
    EXPECT_LT(ate.get(ours, scan), 0.6 * ate.get(ba, scan));
    ratio_sum += stitched.get(ba, scan) / stitched.get(ours, scan);
    // One camera cannot see the others' wobble: the whole panorama is worse than the rig's
    // (measured 14.13 vs 5.06, 12.45 vs 6.90 mm), and the rig tracks even the middle camera better
    // (shared wobble; ATE 3.94 vs 5.97, 2.97 vs 4.65 mm).
    EXPECT_GT(stitched.get(ours_all, scan), 1.5 * stitched.get(rig_all, scan));
    EXPECT_LT(ate.get(rig, scan), 0.8 * ate.get(ours, scan));
    // Ceilings (measured: stitched Ours 3.69 / 2.19, rig middle 3.92 / 1.85, rig all 5.06 / 6.90 mm;
    // ATE Ours 5.97 / 4.65, rig 3.94 / 2.97 mm; axis 0.020 / 0.022 deg single camera, 0.018 / 0.027 deg rig).
    EXPECT_LT(stitched.get(ours, scan), 5.0);
    EXPECT_LT(stitched.get(rig, scan), 5.0);
    EXPECT_LT(stitched.get(rig_all, scan), 9.0);
    EXPECT_LT(ate.get(ours, scan), 8.0);
    EXPECT_LT(ate.get(rig, scan), 5.5);
    EXPECT_LT(axis.get(ours, scan), 0.07);
    EXPECT_LT(axis.get(rig, scan), 0.07);
  }
  // Issue 15's target: the full graph beats BA only by at least 1.5x on average (measured 2.2x).
  EXPECT_GE(ratio_sum / double(stitched.scans.size()), 1.5);

  // Beyond the paper: the depth odometry (track.depth_odometry) between consecutive frames holds
  // the frames of plain wall by their depth as well. Measured (quick, seed 1) SO-1 / SL-1: one
  // camera 2.08 / 0.73 mm against Ours 3.02 / 2.49; the whole rig 4.58 / 3.93 against 6.46 / 6.67;
  // the rig's middle camera 1.45 / 0.58 mm. Fails with the factor off (the rows equal Ours).
  const std::string ours_depth = "Ours + depth odometry (beyond the paper)";
  const std::string rig_depth = "Ours + depth odometry, three cameras (middle camera evaluated)";
  const std::string rig_depth_all = "Ours + depth odometry, three cameras (all cameras evaluated)";
  for (const std::string& scan : stitched.scans) {
    SCOPED_TRACE(scan);
    EXPECT_LT(stitched.get(ours_depth, scan), 0.8 * stitched.get(ours, scan));
    EXPECT_LT(stitched.get(rig_depth_all, scan), 0.85 * stitched.get(rig_all, scan));
    EXPECT_LT(stitched.get(rig_depth, scan), 2.5);
    EXPECT_LT(ate.get(rig_depth, scan), 3.0);
  }
}
