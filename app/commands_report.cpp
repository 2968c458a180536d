// panoscan report: the HTML page of result folders (eval/html_report.h).
#include "commands.h"

#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "panoscan/eval/html_report.h"

namespace fs = std::filesystem;

namespace panoscan::app {

void run_report(const ReportArguments& a) {
  eval::HtmlReportOptions options;
  if (!a.title.empty()) options.title = a.title;
  const std::vector<fs::path> results(a.results.begin(), a.results.end());
  const eval::HtmlReportSummary s = eval::write_html_report(results, a.out, options);
  std::cout << fmt::format("wrote {} ({} sections, {} images, {} tables, {} plots{}; {:.1f} MB)\n", a.out, s.folders,
                           s.images, s.tables, s.plots,
                           s.unknown > 0 ? fmt::format(", {} not recognised", s.unknown) : std::string(),
                           double(s.bytes) / 1e6);
}

}  // namespace panoscan::app
