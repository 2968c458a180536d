// Gate of Table 4 (paper §6.3): registration of the quick-size pair SO-13 (panoramas from
// ground-truth poses, every method from the same ORB guess). Checks the paper's orderings that hold
// on our data, the effect of the measured variance, and ceilings set from the measured values.
//
// Measured over seeds 1-6 (quick size, 2 threads; README "Table 4: what the measured variance
// does"): RMS displacement of the source's pixels from their true place 3.40 (point-to-point),
// 1.51 (point-to-plane), 0.191 (GICP), 0.177 (GICP Ours), 0.196 (Ours with a constant sigma_z),
// 0.449 mm (Ours with the metric surface covariance, the default before issue 17); pair-cloud RMSE
// 3.010 mm for every GICP variant against the noise floor 3.009 mm.
// Robust across seeds, gated on seed 1: point-to-point > point-to-plane > GICP (Ours). Thinner than
// the seed spread, gated over seeds 1-3 (about a minute more): the measured variance against a
// constant sigma_z (0.019 ± 0.017 mm over six seeds, holding on each: the one-seed check flipped on
// seed 2 before issue 17), and the unit surface covariance against the metric one (every seed).
// Ours <= plain GICP holds in 5 of 6 seeds but within noise (0.014 ± 0.016 mm) and is not gated.
// The pair-cloud RMSE of Ours against the constant differs in the fifth digit and is not gated.
// Checked to fail: with the "GICP (Ours)" row run on DepthCovarianceModel::kConstant,
// MeasuredVarianceBeatsAConstantOverSeeds fails; with the metric surface covariance as the
// default, TheUnitSurfaceCovarianceRegistersCloserOverSeeds fails.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "gate_util.h"
#include "panoscan/eval/report.h"
#include "panoscan/eval/statistics.h"
#include "panoscan/tables/tables.h"

using namespace panoscan;

namespace panoscan::tables {
// Defined in benchmarks/tables/src/table4.cpp: the driver's tables on ground-truth-pose panoramas
// (the tracked-pose tables add tracking and two panoramas; `panoscan tables table4` has both).
TableRun run_table4_ground_truth_poses(const TablesOptions& options);
}  // namespace panoscan::tables

namespace {

// Seeds 1-3 (the first is the one-seed run of the single-run checks).
const std::vector<tables::TableRun>& table4_runs() {
  static const std::vector<tables::TableRun> runs = [] {
    std::vector<tables::TableRun> r;
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      tables::TablesOptions options = test::gate_options();
      options.seed = seed;
      r.push_back(tables::run_table4_ground_truth_poses(options));
    }
    return r;
  }();
  return runs;
}

const tables::TableRun& table4_run() { return table4_runs().front(); }

// One row's RMS displacement on each seed.
std::vector<double> displacement_over_seeds(const std::string& row) {
  std::vector<double> values;
  for (const auto& run : table4_runs())
    values.push_back(run.table("Table 4 (registration error): RMS").get(row, "SO-13"));
  return values;
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

TEST(GateTable4, MeasuredVarianceBeatsAConstantOverSeeds) {
  // The per-pixel measured variance against the same model with one sigma_z per panorama (its
  // median): the paired difference over seeds 1-3 is positive and holds on at least two of them.
  const std::vector<double> ours = displacement_over_seeds(kOurs);
  const std::vector<double> constant = displacement_over_seeds("GICP (Ours, constant sigma_z; ablation)");
  const eval::PairedComparison c = eval::compare_paired(ours, constant, true);
  std::cout << "Ours vs constant sigma_z: difference " << c.difference.mean << " mm, holds " << c.holds << " of "
            << c.n << "\n";
  EXPECT_GT(c.difference.mean, 0.0);
  EXPECT_GE(c.holds, 2);
}

TEST(GateTable4, TheUnitSurfaceCovarianceRegistersCloserOverSeeds) {
  // Segal et al.'s unit surface covariance (the default) against the metric one: on every seed.
  const std::vector<double> ours = displacement_over_seeds(kOurs);
  const std::vector<double> metric = displacement_over_seeds("GICP (Ours, metric surface covariance; candidate)");
  for (std::size_t k = 0; k < ours.size(); ++k) EXPECT_LT(ours[k], metric[k]) << "seed " << k + 1;
}

TEST(GateTable4, Ceilings) {
  const tables::TableRun& run = table4_run();
  const eval::ResultTable& rmse = run.table("Table 4:");
  const eval::ResultTable& moved = run.table("Table 4 (registration error): RMS");
  const eval::ResultTable& rotation = run.table("Table 4 (registration error): rotation");
  // Ours: 3.010 mm RMSE, 0.001 mm above the true pose's floor; 0.11-0.23 mm displacement over
  // seeds 1-6 (0.39-0.60 with the metric surface covariance); ~0.003 deg.
  EXPECT_LT(rmse.get(kOurs, kPair), 3.3);
  EXPECT_LT(rmse.get(kOurs, kPair) - rmse.get("Ground-truth relative pose (noise floor, reference)", kPair), 0.05);
  EXPECT_LT(moved.get(kOurs, kPair), 0.5);
  EXPECT_LT(rotation.get(kOurs, kPair), 0.01);
  // Point-to-point: 3.215 mm RMSE (mean over seeds 1-6).
  EXPECT_LT(rmse.get("Point-to-point", kPair), 3.6);
}
