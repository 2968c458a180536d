// One self-contained static HTML page of what result folders hold (`panoscan report`): the table
// records with the paper's figures beside them (and confidence intervals where the record has
// them), panorama previews, error-coloured views, Fig. 8 and trajectory plots, and each run's
// settings, version and source revision. Images are embedded as base64 data URIs and plots drawn
// as inline SVG, so the page needs no other file and no network.
//
// Each folder's kind is told by its files: a table record (<name>.json with "tables", beside its
// .md), a panorama (panorama.json), a `recon track` folder (rig_estimate.json), a scan (rig.json),
// an evaluation (`eval cloud|traj --json` output), a scene or demo folder (clouds, placement.json),
// or a folder of such folders (searched a few levels down). A folder of none of these is shown as
// a note, not an error.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace panoscan::eval {

struct HtmlReportOptions {
  std::string title = "PanoScan results";
  int max_depth = 5;                            // folder levels searched below each results path
  int max_folders = 400;                        // recognised folders shown at most
  std::uintmax_t max_image_bytes = 16u << 20;   // larger images are named, not embedded
};

// What the page holds (counted in the page itself).
struct HtmlReportSummary {
  int folders = 0;  // sections, one per recognised folder
  int images = 0;   // <img> elements (all data URIs)
  int tables = 0;   // <table> elements
  int plots = 0;    // inline SVG plots
  int unknown = 0;  // folders shown as not recognised
  std::size_t bytes = 0;
};

// The page for `results` (folders, or single JSON files from `eval cloud|traj --json` or a table
// record). Throws Error naming a path that does not exist.
std::string html_report(const std::vector<std::filesystem::path>& results, const HtmlReportOptions& options = {},
                        HtmlReportSummary* summary = nullptr);
// Writes html_report(...) to `out` atomically and returns what it holds.
HtmlReportSummary write_html_report(const std::vector<std::filesystem::path>& results,
                                    const std::filesystem::path& out, const HtmlReportOptions& options = {});

// Building blocks, public for the tests.
// &, <, >, " and ' as entities.
std::string html_escape(const std::string& text);
// The Markdown the table drivers write: "#" headings, paragraphs, "**bold**", "`code`", "\|",
// pipe tables (alignment from the separator row), "- " lists and fenced code; everything escaped.
std::string markdown_to_html(const std::string& markdown);

}  // namespace panoscan::eval
