// Gate of Table 4 (paper §6.3): registration of the quick-size pair SO-13 (panoramas from
// ground-truth poses, every method from the same ORB guess). Checks the paper's orderings that hold
// on our data, the effect of the measured variance, and ceilings set from the measured values.
//
// Measured (quick size, 2 threads): RMSE of the pair's cloud 3.193 (point-to-point), 3.065
// (point-to-plane), 3.021 (GICP), 3.023 (GICP Ours), 3.025 (Ours with a constant sigma_z), floor
// with the true pose 3.019 mm; RMS displacement of the source's pixels 3.044 / 1.763 / 0.302 / 0.391
// / 0.543 mm. The paper's "Ours <= plain GICP" does NOT hold here (0.391 vs 0.302 mm; 3.023 vs
// 3.021 mm RMSE, both at the noise floor) and is not gated; see the report of issue 7.
// Checked to fail with the measured variance replaced by a constant (the "GICP (Ours)" row run on
// DepthCovarianceModel::kConstant): MeasuredVarianceBeatsAConstant fails.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "gate_util.h"
#include "panoscan/eval/report.h"
#include "panoscan/tables/tables.h"

using namespace panoscan;

namespace panoscan::tables {
// Defined in benchmarks/tables/src/table4.cpp: the driver's tables on ground-truth-pose panoramas
// (the tracked-pose tables add tracking and two panoramas; `panoscan tables table4` has both).
TableRun run_table4_ground_truth_poses(const TablesOptions& options);
}  // namespace panoscan::tables

namespace {

const tables::TableRun& table4_run() {
  static const tables::TableRun run = tables::run_table4_ground_truth_poses(test::gate_options());
  return run;
}

constexpr const char* kPair = "SO-13";
constexpr const char* kOurs = "GICP (Ours)";

}  // namespace

TEST(GateTable4, EveryRowRegistered) {
  const tables::TableRun& run = table4_run();
  for (const auto& t : run.tables) std::cout << eval::table_to_markdown(t);
  for (const auto& n : run.notes) std::cout << "- " << n << "\n";
  const eval::ResultTable& rmse = run.table("Table 4:");
  for (const std::string& row : rmse.methods) EXPECT_TRUE(std::isfinite(rmse.get(row, kPair))) << row;
  EXPECT_EQ(rmse.methods.size(), 15u);  // 7 of the paper, 1 ablation, 4 Eq. 9 candidates, 2 outside references, the floor
}

TEST(GateTable4, PaperOrderingAgainstPointToPointAndPointToPlane) {
  const tables::TableRun& run = table4_run();
  const eval::ResultTable& rmse = run.table("Table 4:");
  const eval::ResultTable& moved = run.table("Table 4 (registration error): RMS");
  // The paper: point-to-point > point-to-plane > the GICP family on every pair.
  EXPECT_LT(rmse.get("Point-to-plane", kPair), rmse.get("Point-to-point", kPair));
  EXPECT_LT(rmse.get(kOurs, kPair), rmse.get("Point-to-plane", kPair));
  EXPECT_LT(rmse.get(kOurs, kPair), rmse.get("Point-to-plane (Curv)", kPair) + 1e-9);
  EXPECT_LT(moved.get(kOurs, kPair), moved.get("Point-to-plane", kPair));
  EXPECT_LT(moved.get(kOurs, kPair), moved.get("Point-to-point", kPair));
}

TEST(GateTable4, MeasuredVarianceBeatsAConstant) {
  // The per-pixel measured variance against the same model with one sigma_z per panorama (its median).
  const tables::TableRun& run = table4_run();
  const std::string ablation = "GICP (Ours, constant sigma_z; ablation)";
  const eval::ResultTable& moved = run.table("Table 4 (registration error): RMS");
  const eval::ResultTable& rmse = run.table("Table 4:");
  EXPECT_LT(moved.get(kOurs, kPair), moved.get(ablation, kPair));
  EXPECT_LT(rmse.get(kOurs, kPair), rmse.get(ablation, kPair));
}

TEST(GateTable4, Ceilings) {
  const tables::TableRun& run = table4_run();
  const eval::ResultTable& rmse = run.table("Table 4:");
  const eval::ResultTable& moved = run.table("Table 4 (registration error): RMS");
  const eval::ResultTable& rotation = run.table("Table 4 (registration error): rotation");
  // Ours: 3.023 mm RMSE, 0.004 mm above the true pose's floor; 0.39 mm displacement; ~0.001 deg.
  EXPECT_LT(rmse.get(kOurs, kPair), 3.3);
  EXPECT_LT(rmse.get(kOurs, kPair) - rmse.get("Ground-truth relative pose (noise floor, reference)", kPair), 0.05);
  EXPECT_LT(moved.get(kOurs, kPair), 1.0);
  EXPECT_LT(rotation.get(kOurs, kPair), 0.01);
  // Point-to-point: 3.193 mm RMSE.
  EXPECT_LT(rmse.get("Point-to-point", kPair), 3.6);
}
