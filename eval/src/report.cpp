// Paper-style tables (rows: methods, columns: scans) as Markdown and CSV.

#include "panoscan/eval/report.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"

namespace panoscan::eval {

namespace {

std::size_t index_of(std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return i;
  names.push_back(name);
  return names.size() - 1;
}

std::string format_number(double value, const char* format, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, format, decimals, value);
  return text;
}

std::string markdown_cell(std::string text) {
  std::string out;
  for (char c : text) {
    if (c == '|')
      out += "\\|";
    else if (c == '\n' || c == '\r')
      out += ' ';
    else
      out += c;
  }
  return out;
}

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

void ResultTable::set(const std::string& method, const std::string& scan, double value) {
  const std::size_t row = index_of(methods, method);
  const std::size_t column = index_of(scans, scan);
  values.resize(methods.size());
  for (auto& r : values) r.resize(scans.size(), std::numeric_limits<double>::quiet_NaN());
  values[row][column] = value;
}

double ResultTable::get(const std::string& method, const std::string& scan) const {
  for (std::size_t r = 0; r < methods.size(); ++r)
    if (methods[r] == method)
      for (std::size_t c = 0; c < scans.size(); ++c)
        if (scans[c] == scan && r < values.size() && c < values[r].size()) return values[r][c];
  return std::numeric_limits<double>::quiet_NaN();
}

std::string table_to_markdown(const ResultTable& table) {
  auto cell_value = [&](std::size_t r, std::size_t c) {
    return (r < table.values.size() && c < table.values[r].size()) ? table.values[r][c]
                                                                   : std::numeric_limits<double>::quiet_NaN();
  };
  std::string out;
  if (!table.title.empty()) out += "**" + markdown_cell(table.title) + "**\n\n";
  out += "| Method" + (table.unit.empty() ? std::string() : " (" + table.unit + ")") + " |";
  for (const auto& scan : table.scans) out += " " + markdown_cell(scan) + " |";
  out += "\n|---|";
  for (std::size_t c = 0; c < table.scans.size(); ++c) out += "---:|";
  out += "\n";
  // Best per column, compared on the printed (rounded) value so that ties are all bold.
  std::vector<std::string> best(table.scans.size());
  for (std::size_t c = 0; c < table.scans.size(); ++c) {
    double best_value = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t r = 0; r < table.methods.size(); ++r) {
      const double v = cell_value(r, c);
      if (std::isnan(v)) continue;
      if (std::isnan(best_value) || (table.lower_is_better ? v < best_value : v > best_value)) best_value = v;
    }
    if (!std::isnan(best_value)) best[c] = format_number(best_value, "%.*f", table.decimals);
  }
  for (std::size_t r = 0; r < table.methods.size(); ++r) {
    out += "| " + markdown_cell(table.methods[r]) + " |";
    for (std::size_t c = 0; c < table.scans.size(); ++c) {
      const double v = cell_value(r, c);
      if (std::isnan(v)) {
        out += " - |";
        continue;
      }
      const std::string text = format_number(v, "%.*f", table.decimals);
      const bool bold = table.methods.size() > 1 && text == best[c];
      out += " " + (bold ? "**" + text + "**" : text) + " |";
    }
    out += "\n";
  }
  return out;
}

std::string table_to_csv(const ResultTable& table) {
  std::string out = "method";
  for (const auto& scan : table.scans) out += "," + csv_cell(scan);
  out += "\n";
  for (std::size_t r = 0; r < table.methods.size(); ++r) {
    out += csv_cell(table.methods[r]);
    for (std::size_t c = 0; c < table.scans.size(); ++c) {
      const double v = (r < table.values.size() && c < table.values[r].size())
                           ? table.values[r][c]
                           : std::numeric_limits<double>::quiet_NaN();
      out += ",";
      if (!std::isnan(v)) out += format_number(v, "%.*g", 6);
    }
    out += "\n";
  }
  return out;
}

void write_table(const std::filesystem::path& base_path, const ResultTable& table) {
  std::filesystem::path markdown = base_path, csv = base_path;
  markdown += ".md";
  csv += ".csv";
  write_file_atomic(markdown, table_to_markdown(table));
  write_file_atomic(csv, table_to_csv(table));
}

}  // namespace panoscan::eval
