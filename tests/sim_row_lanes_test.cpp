// The renderer's row passes (sim/src/row_lanes.h) for every lane type against one lane: on a CPU with
// AVX, render() only ever runs the AVX instantiation, so the Renderer tests alone would not run the
// SSE one. Random rows with misses, rays from behind the surface and lights behind it.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "../sim/src/row_lanes.h"

namespace panoscan::render_rows {
namespace {

constexpr int kPadded = 48;  // a multiple of every lane width

RowScratch random_row(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.f, 1.f), depth(0.3f, 6.f);
  RowScratch row(kPadded);
  for (int x = 0; x < kPadded; ++x) {
    row.t[x] = depth(rng);
    row.dir_x[x] = 0.6f * unit(rng), row.dir_y[x] = 0.5f * unit(rng), row.dir_z[x] = 1.f;
    Eigen::Vector3f n(unit(rng), unit(rng), unit(rng));
    n.normalize();
    row.normal_x[x] = n.x(), row.normal_y[x] = n.y(), row.normal_z[x] = n.z();
    row.hit[x] = rng() % 5 == 0 ? 0 : -1;
  }
  return row;
}

std::vector<float> outputs(const RowScratch& row) {
  std::vector<float> all;
  for (const std::vector<float>* plane : {&row.normal_x, &row.normal_y, &row.normal_z, &row.point_x, &row.point_y,
                                          &row.point_z, &row.footprint, &row.incidence, &row.depth, &row.diffuse})
    all.insert(all.end(), plane->begin(), plane->end());
  return all;
}

template <typename L>
std::vector<float> run_passes(std::uint32_t seed, const LightArrays& lights) {
  RowScratch row = random_row(seed);
  row_geometry_lanes<L>(row, kPadded, Eigen::Vector3f(0.3f, -0.2f, 1.2f), 1.f / 570.f);
  row_diffuse_lanes<L>(row, kPadded, lights);
  return outputs(row);
}

TEST(RowLanes, EveryLaneTypeGivesTheOneLaneValuesBitForBit) {
  const std::vector<float> x{-1.5f, 0.4f, 2.f, 0.f, 1.f}, y{0.3f, -1.f, 0.5f, 2.f, -2.f}, z{2.4f, 2.4f, 0.2f, 1.f, 2.f},
      intensity{0.5f, 0.7f, 0.9f, 1.1f, 0.2f};
  const LightArrays lights{x, y, z, intensity, x.size()};
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    const std::vector<float> reference = run_passes<ScalarLanes>(seed, lights);
    // Not vacuous: lit and unlit pixels, misses.
    EXPECT_GT(std::count_if(reference.end() - kPadded, reference.end(), [](float d) { return d > 0.f; }), 0);
#if defined(__SSE2__)
    EXPECT_EQ(run_passes<SseLanes>(seed, lights), reference) << "seed " << seed;
#endif
#if defined(PANOSCAN_ROW_LANES_AVX)
    if (__builtin_cpu_supports("avx")) {
      RowScratch row = random_row(seed);
      row_geometry_avx(row, kPadded, Eigen::Vector3f(0.3f, -0.2f, 1.2f), 1.f / 570.f);
      row_diffuse_avx(row, kPadded, lights);
      EXPECT_EQ(outputs(row), reference) << "seed " << seed;
    }
#endif
  }
}

}  // namespace
}  // namespace panoscan::render_rows
