// Paper-style tables, colour maps and the error-coloured PLY.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/colour_map.h"
#include "panoscan/eval/coloured_cloud.h"
#include "panoscan/eval/report.h"
#include "test_util.h"

namespace panoscan::eval {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

ResultTable fusion_table() {
  ResultTable table;
  table.title = "Table 3: fusion";
  table.set("ERP Ave.", "SL-1", 4.42);
  table.set("ERP Ave.", "SO-1", 7.5);
  table.set("TSA-L1", "SL-1", 3.51);
  table.set("TSA-L1", "SO-1", 6.2);
  table.set("TV-L1", "SL-1", 3.6);
  return table;
}

TEST(Report, MarkdownLikeThePaper) {
  const ResultTable table = fusion_table();
  EXPECT_EQ(table.methods.size(), 3u);
  EXPECT_EQ(table.scans, (std::vector<std::string>{"SL-1", "SO-1"}));
  EXPECT_DOUBLE_EQ(table.get("TSA-L1", "SO-1"), 6.2);
  EXPECT_TRUE(std::isnan(table.get("TV-L1", "SO-1")));
  EXPECT_EQ(table_to_markdown(table),
            "**Table 3: fusion**\n\n"
            "| Method (mm) | SL-1 | SO-1 |\n"
            "|---|---:|---:|\n"
            "| ERP Ave. | 4.4 | 7.5 |\n"
            "| TSA-L1 | **3.5** | **6.2** |\n"
            "| TV-L1 | 3.6 | - |\n");
}

TEST(Report, CsvAndFiles) {
  testutil::TempDir dir("report");
  ResultTable table = fusion_table();
  table.set("p2plane, weighted", "SL-1", 4.0);
  EXPECT_EQ(table_to_csv(table),
            "method,SL-1,SO-1\n"
            "ERP Ave.,4.42,7.5\n"
            "TSA-L1,3.51,6.2\n"
            "TV-L1,3.6,\n"
            "\"p2plane, weighted\",4,\n");
  write_table(dir / "table3", table);
  EXPECT_EQ(read_text(dir / "table3.md"), table_to_markdown(table));
  EXPECT_EQ(read_text(dir / "table3.csv"), table_to_csv(table));
}

TEST(Report, VersionAndRevisionAreCompiledIn) {
  EXPECT_FALSE(project_version().empty());
  EXPECT_NE(project_version(), "unknown");
  // From a git checkout (CI clones the repository) the revision is a hexadecimal commit, with
  // "-dirty-<hash of the changes>" when built from uncommitted changes; from an exported source tree it is "unknown".
  if (std::filesystem::exists(std::filesystem::path(PANOSCAN_SOURCE_DIR) / ".git"))
    EXPECT_THAT(source_revision(), MatchesRegex("([0-9a-f]{12}|.*-g[0-9a-f]{12})(-dirty-[0-9a-f]{10})?"));
  else
    EXPECT_EQ(source_revision(), "unknown");
}

TEST(ColourMap, EndpointsClampingAndNames) {
  EXPECT_EQ(colour_at(ColourMap::kViridis, 0.0), (Rgb8{68, 1, 84}));
  EXPECT_EQ(colour_at(ColourMap::kViridis, 1.0), (Rgb8{253, 231, 37}));
  EXPECT_EQ(colour_at(ColourMap::kViridis, 7.0), colour_at(ColourMap::kViridis, 1.0));
  EXPECT_EQ(colour_at(ColourMap::kTurbo, -1.0), colour_at(ColourMap::kTurbo, 0.0));
  EXPECT_EQ(colour_at(ColourMap::kTurbo, std::nan("")), (Rgb8{0, 0, 0}));
  EXPECT_EQ(parse_colour_map("turbo"), ColourMap::kTurbo);
  EXPECT_THROW(parse_colour_map("jet"), Error);
  ColourLegend legend;
  legend.min = 0.0;
  legend.max = 0.05;
  EXPECT_EQ(legend.colour(0.025), colour_at(ColourMap::kViridis, 0.5));
  EXPECT_THAT(legend.describe(), HasSubstr("0.05"));
}

TEST(ColouredCloud, ColoursDistancesAndLegendInTheFile) {
  testutil::TempDir dir("coloured");
  PointCloud cloud;
  cloud.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  const std::vector<double> distances = {0.0, 0.02, 0.5};
  const ColourLegend legend =
      write_error_coloured_ply(dir / "err.ply", cloud, distances, {ColourMap::kTurbo, 0.0, 0.04});
  EXPECT_DOUBLE_EQ(legend.max, 0.04);
  const PointCloud back = read_ply_point_cloud(dir / "err.ply");
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back.colours[0], colour_at(ColourMap::kTurbo, 0.0));
  EXPECT_EQ(back.colours[1], colour_at(ColourMap::kTurbo, 0.5));
  EXPECT_EQ(back.colours[2], colour_at(ColourMap::kTurbo, 1.0));  // clamped
  const std::string text = read_text(dir / "err.ply");
  EXPECT_THAT(text, HasSubstr("comment panoscan_colour_map turbo\n"));
  EXPECT_THAT(text, HasSubstr("comment panoscan_colour_range_m 0 0.04\n"));
  EXPECT_THAT(text, HasSubstr("property float distance\n"));
  // Automatic range: the 99th percentile.
  const ColourLegend automatic =
      write_error_coloured_ply(dir / "auto.ply", cloud, distances, {ColourMap::kViridis, 0.0, 0.0});
  EXPECT_NEAR(automatic.max, 0.02 + 0.98 * 0.48, 1e-12);
  EXPECT_THROW(write_error_coloured_ply(dir / "bad.ply", cloud, {0.1}), Error);
}

}  // namespace
}  // namespace panoscan::eval
