// Tables laid out like the paper's (rows: methods, columns: scans, e.g. "SL-1", "SO-3"), as
// Markdown and CSV. (The version every JSON report carries is in panoscan/core/version.h.)
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace panoscan::eval {

struct ResultTable {
  std::string title;  // e.g. "Table 3: fusion, RMSE"
  std::string unit = "mm";
  std::vector<std::string> methods;         // rows, in insertion order
  std::vector<std::string> scans;           // columns, in insertion order
  std::vector<std::vector<double>> values;  // [method][scan]; NaN = not measured
  int decimals = 1;
  bool lower_is_better = true;  // the best value of each column is set in bold (Markdown)

  // Sets a cell, adding the method row and the scan column if they are new.
  void set(const std::string& method, const std::string& scan, double value);
  double get(const std::string& method, const std::string& scan) const;  // NaN if absent
};

// Markdown: a title line, then "| Method | scan... |" with the unit in the header, missing cells
// as "-", the best value of each column in bold.
std::string table_to_markdown(const ResultTable& table);
// CSV: "method,<scan>,..." then one line per method; full precision (%.6g), missing cells empty.
std::string table_to_csv(const ResultTable& table);
// Writes <base>.md and <base>.csv atomically.
void write_table(const std::filesystem::path& base_path, const ResultTable& table);

}  // namespace panoscan::eval
