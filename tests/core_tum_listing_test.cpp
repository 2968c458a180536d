// Tests of the TUM listing reader (read_tum_listing, shared by the scan reader and `import tum`) and
// of associate_timestamps (TUM's associate.py): each refusal names the listing and the line; the
// association's edge cases (ties, reuse, the window bound, crossing pairs, empty input).

#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/tum_listing.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testutil::error_of;
using testutil::TempDir;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

class TumListingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    write_text(dir_ / "rgb" / "1.0.png", "x");
    write_text(dir_ / "rgb" / "1.1.png", "x");
  }
  fs::path write_listing(const std::string& text) {
    const fs::path path = dir_ / "rgb.txt";
    write_text(path, text);
    return path;
  }
  TempDir dir_{"tum-listing"};
};

TEST_F(TumListingTest, ReadsEntriesSkippingCommentsBlankLinesAndCarriageReturns) {
  const fs::path listing =
      write_listing("# color images\n# timestamp filename\n\n  \n1.0 rgb/1.0.png\r\n  # indented comment\n"
                    "1.100000\trgb/1.1.png\n");
  const std::vector<TumListingEntry> entries = read_tum_listing(listing, dir_.path());
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_DOUBLE_EQ(entries[0].timestamp, 1.0);
  EXPECT_EQ(entries[0].timestamp_text, "1.0");
  EXPECT_EQ(entries[0].file, "rgb/1.0.png");
  EXPECT_EQ(entries[0].line_number, 5u);
  EXPECT_DOUBLE_EQ(entries[1].timestamp, 1.1);
  EXPECT_EQ(entries[1].line_number, 7u);
}

TEST_F(TumListingTest, EachRefusalNamesTheListingAndTheLine) {
  struct Case {
    std::string text, line, what;
  };
  const std::vector<Case> cases = {
      {"1.0 rgb/1.0.png\n1.1 rgb/missing.png\n", "line 2", "listed file not found"},
      {"1.1 rgb/1.1.png\n1.0 rgb/1.0.png\n", "line 2", "is before the previous one"},
      {"1.0 rgb/1.0.png\n1.0 rgb/1.1.png\n", "line 2", "repeats"},
      {"# c\n1.0 rgb/1.0.png extra\n", "line 2", "found 3 fields"},
      {"1.0\n", "line 1", "found 1 fields"},
      {"nan rgb/1.0.png\n", "line 1", "not a finite number"},
      {"1e999 rgb/1.0.png\n", "line 1", "not a finite number"},
      {"1.0x rgb/1.0.png\n", "line 1", "not a finite number"},
      {"1.0 ../rgb.txt\n", "line 1", "must be a path relative to"},
      {"1.0 /etc/passwd\n", "line 1", "must be a path relative to"},
      {"1.0 rgb\n", "line 1", "listed file not found"},  // a folder is not an image
  };
  for (const Case& c : cases) {
    const fs::path listing = write_listing(c.text);
    const std::string message = error_of([&] { read_tum_listing(listing, dir_.path()); });
    EXPECT_THAT(message, HasSubstr(listing.string() + ": " + c.line + ": ")) << c.text;
    EXPECT_THAT(message, HasSubstr(c.what)) << c.text;
  }
}

TEST_F(TumListingTest, MissingEmptyAndFolderListingsNameTheFile) {
  const fs::path missing = dir_ / "nothing.txt";
  EXPECT_THAT(error_of([&] { read_tum_listing(missing, dir_.path()); }),
              HasSubstr(missing.string() + ": listing not found"));
  const fs::path empty = write_listing("# only a comment\n\n");
  EXPECT_THAT(error_of([&] { read_tum_listing(empty, dir_.path()); }),
              HasSubstr(empty.string() + ": the listing holds no frames"));
  EXPECT_THAT(error_of([&] { read_tum_listing(dir_ / "rgb", dir_.path()); }), HasSubstr("is a directory"));
}

std::vector<std::pair<std::size_t, std::size_t>> index_pairs(const std::vector<TimestampPair>& pairs) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const TimestampPair& p : pairs) out.emplace_back(p.rgb, p.depth);
  return out;
}

using Pairs = std::vector<std::pair<std::size_t, std::size_t>>;

TEST(AssociateTimestamps, NearestWithinTheWindowEachUsedOnce) {
  // Depth 5 ms after colour, plus one depth image far from any colour image.
  const std::vector<double> rgb = {1.000, 1.033, 1.066, 1.100};
  const std::vector<double> depth = {1.005, 1.038, 1.071, 1.5, 1.105};
  const std::vector<TimestampPair> pairs = associate_timestamps(rgb, {1.005, 1.038, 1.071, 1.105}, 0.02);
  EXPECT_EQ(index_pairs(pairs), (Pairs{{0, 0}, {1, 1}, {2, 2}, {3, 3}}));
  EXPECT_NEAR(pairs[0].dt, 0.005, 1e-12);
  // The depth list must be sorted: 1.5 before 1.105 is refused.
  EXPECT_THAT(error_of([&] { associate_timestamps(rgb, depth, 0.02); }), HasSubstr("depth timestamps"));
}

TEST(AssociateTimestamps, GreedyBySmallestDifferenceNotByOrder) {
  // Both colour images are within the window of the one depth image: it goes to the closer one
  // (rgb 0, 2 ms) and rgb 1 stays unpaired, whatever the order.
  const std::vector<TimestampPair> pairs = associate_timestamps({1.000, 1.012}, {1.002}, 0.02);
  EXPECT_EQ(index_pairs(pairs), (Pairs{{0, 0}}));
  EXPECT_EQ(index_pairs(associate_timestamps({0.990, 1.000}, {1.002}, 0.02)), (Pairs{{1, 0}}));
  // Two colour images at the same distance from one depth image (binary-exact): the earlier wins.
  EXPECT_EQ(index_pairs(associate_timestamps({0.75, 1.25}, {1.0}, 0.5)), (Pairs{{0, 0}}));
  // Pairs may cross in time; the result is in colour-timestamp order.
  const std::vector<TimestampPair> crossing = associate_timestamps({1.000, 1.010}, {1.009, 1.0115}, 0.02);
  EXPECT_EQ(index_pairs(crossing), (Pairs{{0, 1}, {1, 0}}));
}

TEST(AssociateTimestamps, TheWindowIsStrictAndEmptyInputsGiveNoPairs) {
  // associate.py keeps |dt| < max_difference: exactly max_dt apart is not a pair.
  EXPECT_TRUE(associate_timestamps({1.0}, {1.5}, 0.5).empty());
  EXPECT_EQ(associate_timestamps({1.0}, {1.49}, 0.5).size(), 1u);
  EXPECT_EQ(associate_timestamps({1.0}, {0.51}, 0.5).size(), 1u);
  EXPECT_TRUE(associate_timestamps({}, {1.0}, 0.02).empty());
  EXPECT_TRUE(associate_timestamps({1.0}, {}, 0.02).empty());
  EXPECT_TRUE(associate_timestamps({1.0, 2.0}, {1.5}, 0.02).empty());
  // Equal timestamps pair exactly.
  const std::vector<TimestampPair> same = associate_timestamps({1.0, 2.0}, {1.0, 2.0}, 0.02);
  EXPECT_EQ(index_pairs(same), (Pairs{{0, 0}, {1, 1}}));
  EXPECT_EQ(same[1].dt, 0.0);
}

TEST(AssociateTimestamps, RefusesABadWindow) {
  for (double bad : {0.0, -0.01, std::nan(""), 1.0 / 0.0}) {
    EXPECT_THAT(error_of([&] { associate_timestamps({1.0}, {1.0}, bad); }), HasSubstr("max_dt")) << bad;
  }
}

}  // namespace
}  // namespace panoscan
