// The HTML report (eval/html_report.h) on hand-made result folders: escaping, the drivers' Markdown,
// each folder kind, an unknown folder, a missing path. The browser check is report_browser_test.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/error.h"
#include "panoscan/eval/html_report.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace panoscan;
using namespace panoscan::eval;
using panoscan::testutil::TempDir;

namespace {

// A 1x1 PNG and its base64 form.
const std::string kPngBase64 =
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==";

std::string decode_base64(const std::string& text) {
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned buffer = 0;
  int bits = 0;
  for (char c : text) {
    if (c == '=') break;
    buffer = (buffer << 6) | unsigned(alphabet.find(c));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += char((buffer >> bits) & 0xFF);
    }
  }
  return out;
}

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::size_t count(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

// A table record as the drivers write it (tables.cpp): <name>.json, <name>.md.
void write_record(const fs::path& dir, bool with_markdown) {
  nlohmann::json j = {
      {"table", "table9"},
      {"description", "a test table <b>"},
      {"version", "9.9.9"},
      {"source_revision", "abcdef123456"},
      {"date_utc", "2026-01-01T00:00:00Z"},
      {"settings", {{"size", "quick"}, {"nested", {{"inner", 3}}}}},
      {"notes", {"Paper (Table 9): SO-1 1.23", "ours only"}},
      {"tables",
       {{{"title", "Table 9: errors"},
         {"unit", "mm"},
         {"lower_is_better", true},
         {"values", {{"A", {{"SO-1", 2.5}, {"SL-1", 1.0}}}, {"B", {{"SO-1", 1.5}, {"SL-1", 3.0}}}}}}}}};
  write(dir / "table9.json", j.dump(2));
  if (with_markdown)
    write(dir / "table9.md",
          "**Table 9: errors <script>alert(1)</script>**\n\n| Method (mm) | SO-1 | SL-1 |\n|---|---:|---:|\n"
          "| A | 2.50 | **1.00** |\n| B | **1.50** | 3.00 |\n\nNotes:\n- Paper (Table 9): SO-1 1.23\n");
}

}  // namespace

TEST(HtmlReport, EscapesText) {
  EXPECT_EQ(html_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
  EXPECT_EQ(html_escape("plain"), "plain");
}

TEST(HtmlReport, MarkdownOfTheDrivers) {
  const std::string html = markdown_to_html(
      "# Title\n\n**Table 3: x** (mm)\n\n| Method (mm) | SO-1 | a \\| b |\n|---|---:|---:|\n| TSDF <x> | **3.20** | 1 |\n\n"
      "Notes:\n- one `code`\n- two\n\n| Claim | verdict |\n|---|---|\n| c | holds |\n| d | reversed |\n");
  EXPECT_NE(html.find("<h3>Title</h3>"), std::string::npos) << html;
  EXPECT_NE(html.find("<p><strong>Table 3: x</strong> (mm)</p>"), std::string::npos) << html;
  EXPECT_NE(html.find("<th class=\"r\">a | b</th>"), std::string::npos) << html;  // escaped pipe kept in the cell
  EXPECT_NE(html.find("<td>TSDF &lt;x&gt;</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td class=\"r\"><strong>3.20</strong></td>"), std::string::npos) << html;
  EXPECT_NE(html.find("<li>one <code>code</code></li>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td class=\"holds\">holds</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td class=\"reversed\">reversed</td>"), std::string::npos) << html;
  EXPECT_EQ(count(html, "<table>"), 2u);
}

TEST(HtmlReport, EachFolderKind) {
  TempDir tmp("html-report");
  const std::string png = decode_base64(kPngBase64);
  // A record with its Markdown and a PNG beside it, one without (tables from the JSON).
  write_record(tmp / "results" / "table9", true);
  write(tmp / "results" / "table9" / "plot.png", png);
  write_record(tmp / "results" / "nomd", false);
  // A panorama folder.
  write(tmp / "pano" / "panorama.json",
        nlohmann::json{{"format", "panoscan-panorama"},
                       {"version", 1},
                       {"width", 2},
                       {"height", 1},
                       {"method", "tsa"},
                       {"written_by", {{"version", "9.9.9"}, {"source_revision", "pano-rev"}}}}
            .dump());
  for (const char* name : {"colour.png", "depth.png", "variance.png"}) write(tmp / "pano" / name, png);
  // A track folder (no scan: the plot shows the estimate alone).
  write(tmp / "track" / "rig_estimate.json",
        nlohmann::json{{"format", "panoscan-rig-trajectory"},
                       {"version", 1},
                       {"source", "tracked:full"},
                       {"world_from_axis", {{"translation", {0, 0, 0}}, {"rotation_quaternion_xyzw", {0, 0, 0, 1}}}}}
            .dump());
  write(tmp / "track" / "cam0.txt", "# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n2 0.1 0.1 0 0 0 0 1\n");
  write(tmp / "unknown" / "notes.txt", "nothing");

  HtmlReportSummary summary;
  const std::string html = html_report({tmp / "results", tmp / "pano", tmp / "track", tmp / "unknown"}, {}, &summary);
  // Escaped everywhere; the only script is the page's own check.
  EXPECT_EQ(html.find("<script>alert"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;alert(1)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("a test table &lt;b&gt;"), std::string::npos);
  EXPECT_EQ(count(html, "<script>"), 1u);
  EXPECT_EQ(html.find("http://"), std::string::npos);   // nothing to fetch
  EXPECT_EQ(html.find("https://"), std::string::npos);
  // Provenance, the paper's note beside the tables, the JSON fallback with the best value bold.
  EXPECT_NE(html.find("abcdef123456"), std::string::npos);
  EXPECT_NE(html.find("9.9.9"), std::string::npos);
  EXPECT_NE(html.find("<aside>"), std::string::npos);
  EXPECT_NE(html.find("Paper (Table 9): SO-1 1.23"), std::string::npos);
  EXPECT_NE(html.find("nested.inner = 3"), std::string::npos);
  EXPECT_NE(html.find("No table9.md beside the record"), std::string::npos);
  EXPECT_NE(html.find("<strong>1.50</strong>"), std::string::npos);
  // Images embedded as data URIs, byte for byte.
  EXPECT_EQ(count(html, "src=\"data:image/png;base64," + kPngBase64 + "\""), 4u);
  EXPECT_EQ(summary.images, 4);
  EXPECT_NE(html.find("pano-rev"), std::string::npos);
  // The track's plot; the unknown folder as a note.
  EXPECT_EQ(summary.plots, 1);
  EXPECT_NE(html.find("no ground truth"), std::string::npos);
  EXPECT_EQ(summary.unknown, 1);
  EXPECT_NE(html.find("notes.txt"), std::string::npos);
  EXPECT_GE(summary.tables, 3);
  EXPECT_NE(html.find("id=\"report-check\""), std::string::npos);
}

TEST(HtmlReport, Fig8PlottedFromTheSweepWithoutItsPng) {
  TempDir tmp("html-report-fig8");
  write(tmp / "fig8" / "fig8.json",
        nlohmann::json{{"table", "fig8"}, {"tables", nlohmann::json::array()}, {"version", "1"}}.dump());
  write(tmp / "fig8" / "fig8_sweep.csv",
        "scan,n,frames,landmarks,ate_mm,stitched_rmse_mm,optimisation_s,frontend_s,iterations,converged\n"
        "SO-1,1,100,10,3.5,5.4,351.4,9.0,53,1\nSO-1,16,10,5,4.2,5.1,5.8,1.2,29,1\n");
  HtmlReportSummary summary;
  const std::string html = html_report({tmp / "fig8"}, {}, &summary);
  EXPECT_EQ(summary.plots, 2);
  EXPECT_NE(html.find("Plotted from fig8_sweep.csv"), std::string::npos);
}

TEST(HtmlReport, MissingPathIsAnErrorNamingIt) {
  TempDir tmp("html-report-missing");
  const std::string message = panoscan::testutil::error_of([&] { html_report({tmp / "nowhere"}); });
  EXPECT_NE(message.find("nowhere"), std::string::npos) << message;
  EXPECT_NE(panoscan::testutil::error_of([&] { html_report({}); }).find("--results"), std::string::npos);
}

TEST(HtmlReport, WritesTheFileAtomically) {
  TempDir tmp("html-report-write");
  write_record(tmp / "table9", true);
  const fs::path out = tmp / "out" / "report.html";
  const HtmlReportSummary summary = write_html_report({tmp / "table9"}, out);
  ASSERT_TRUE(fs::exists(out));
  EXPECT_EQ(fs::file_size(out), summary.bytes);
  std::size_t files = 0;
  for (auto it = fs::directory_iterator(tmp / "out"); it != fs::directory_iterator(); ++it) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left beside it
}
