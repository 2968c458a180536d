// The static HTML report of result folders (html_report.h). Everything the page shows is read from
// the folders' own files; nothing is recomputed except the plots' geometry.
#include "panoscan/eval/html_report.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/groundtruth.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace panoscan::eval {

std::string html_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {

// ---------------------------------------------------------------- small helpers

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

std::optional<std::string> read_text(const fs::path& path, std::uintmax_t max_bytes = 64u << 20) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  const auto size = fs::file_size(path, ec);
  if (ec || size > max_bytes) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::optional<json> read_json(const fs::path& path, std::uintmax_t max_bytes = 16u << 20) {
  const auto text = read_text(path, max_bytes);
  if (!text) return std::nullopt;
  try {
    json j = json::parse(*text);
    if (!j.is_object()) return std::nullopt;
    return j;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A JSON value as short text: strings bare, numbers with up to 6 significant digits.
std::string value_text(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) return fmt::format("{:.6g}", v.get<double>());
  if (v.is_null()) return "n/a";
  std::string text = v.dump();
  if (text.size() > 160) text = text.substr(0, 157) + "...";
  return text;
}

std::string string_field(const json& j, const std::string& key, const std::string& fallback = "") {
  if (j.is_object() && j.contains(key) && j[key].is_string()) return j[key].get<std::string>();
  return fallback;
}

std::string base64(const std::string& bytes) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned n = (unsigned(std::uint8_t(bytes[i])) << 16) | (unsigned(std::uint8_t(bytes[i + 1])) << 8) |
                       unsigned(std::uint8_t(bytes[i + 2]));
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    out += alphabet[(n >> 6) & 63];
    out += alphabet[n & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned n = unsigned(std::uint8_t(bytes[i])) << 16;
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned n = (unsigned(std::uint8_t(bytes[i])) << 16) | (unsigned(std::uint8_t(bytes[i + 1])) << 8);
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    out += alphabet[(n >> 6) & 63];
    out += '=';
  }
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::optional<std::string> image_mime(const fs::path& path) {
  const std::string ext = lower(path.extension().string());
  if (ext == ".png") return "image/png";
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  return std::nullopt;
}

// The sorted entries of a folder, files or folders; hidden names (".x", temporaries) left out.
std::vector<fs::path> entries(const fs::path& dir, bool folders) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    std::error_code type_ec;
    const bool is_dir = it->is_directory(type_ec);
    if (type_ec) continue;
    if (is_dir == folders && (folders || it->is_regular_file(type_ec))) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M UTC", &tm);
  return text;
}

// "element vertex N" of a PLY header, or -1.
long long ply_vertex_count(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  for (int i = 0; i < 64 && std::getline(in, line); ++i) {
    if (starts_with(line, "element vertex ")) {
      try {
        return std::stoll(line.substr(15));
      } catch (const std::exception&) {
        return -1;
      }
    }
    if (starts_with(line, "end_header")) break;
  }
  return -1;
}

// "(x, y, z) m" of a JSON list of three numbers.
std::string point_text(const json& p) {
  if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() || !p[2].is_number()) return value_text(p);
  return fmt::format("({:.3f}, {:.3f}, {:.3f}) m", p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
}

std::string megabytes(std::uintmax_t bytes) { return fmt::format("{:.1f} MB", double(bytes) / 1e6); }

// ---------------------------------------------------------------- Markdown (the drivers' subset)

std::string inline_markdown(const std::string& text) {
  std::string out;
  bool strong = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\\' && i + 1 < text.size() && std::ispunct(static_cast<unsigned char>(text[i + 1]))) {
      out += html_escape(std::string(1, text[++i]));
    } else if (c == '`') {
      const auto close = text.find('`', i + 1);
      if (close == std::string::npos) {
        out += "`";
        continue;
      }
      out += "<code>" + html_escape(text.substr(i + 1, close - i - 1)) + "</code>";
      i = close;
    } else if (c == '*' && i + 1 < text.size() && text[i + 1] == '*') {
      out += strong ? "</strong>" : "<strong>";
      strong = !strong;
      ++i;
    } else {
      out += html_escape(std::string(1, c));
    }
  }
  if (strong) out += "</strong>";
  return out;
}

// The cells of a pipe-table row ("| a | b \| c |"), escapes kept for inline_markdown.
std::vector<std::string> table_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::string row = trim(line);
  if (!row.empty() && row.front() == '|') row.erase(0, 1);
  for (std::size_t i = 0; i < row.size(); ++i) {
    if (row[i] == '\\' && i + 1 < row.size()) {
      cell += row[i];
      cell += row[++i];
    } else if (row[i] == '|') {
      cells.push_back(trim(cell));
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  if (!trim(cell).empty()) cells.push_back(trim(cell));
  return cells;
}

bool is_separator_row(const std::vector<std::string>& cells) {
  if (cells.empty()) return false;
  for (const auto& c : cells) {
    if (c.empty()) return false;
    for (char ch : c)
      if (ch != '-' && ch != ':' && ch != ' ') return false;
  }
  return true;
}

std::string verdict_class(const std::string& cell) {
  if (cell == "holds") return " class=\"holds\"";
  if (cell == "reversed") return " class=\"reversed\"";
  if (cell == "within noise") return " class=\"noise\"";
  return "";
}

std::string markdown_table(const std::vector<std::string>& lines) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& l : lines) rows.push_back(table_cells(l));
  std::vector<std::string> align;
  std::size_t body_start = 0;
  std::string out = "<div class=\"table-wrap\"><table>";
  if (rows.size() >= 2 && is_separator_row(rows[1])) {
    for (const auto& c : rows[1]) align.push_back(c.back() == ':' ? " class=\"r\"" : "");
    out += "<thead><tr>";
    for (std::size_t k = 0; k < rows[0].size(); ++k)
      out += "<th" + (k < align.size() ? align[k] : std::string()) + ">" + inline_markdown(rows[0][k]) + "</th>";
    out += "</tr></thead>";
    body_start = 2;
  }
  out += "<tbody>";
  for (std::size_t r = body_start; r < rows.size(); ++r) {
    out += "<tr>";
    for (std::size_t k = 0; k < rows[r].size(); ++k) {
      std::string attributes = k < align.size() ? align[k] : std::string();
      const std::string verdict = verdict_class(rows[r][k]);
      if (!verdict.empty()) attributes = verdict;
      out += "<td" + attributes + ">" + inline_markdown(rows[r][k]) + "</td>";
    }
    out += "</tr>";
  }
  out += "</tbody></table></div>\n";
  return out;
}

}  // namespace

std::string markdown_to_html(const std::string& markdown) {
  std::vector<std::string> lines;
  {
    std::istringstream in(markdown);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines.push_back(line);
    }
  }
  std::string out, paragraph;
  auto flush_paragraph = [&] {
    if (!paragraph.empty()) out += "<p>" + inline_markdown(paragraph) + "</p>\n";
    paragraph.clear();
  };
  for (std::size_t i = 0; i < lines.size();) {
    const std::string line = trim(lines[i]);
    if (starts_with(line, "```")) {
      flush_paragraph();
      std::string code;
      for (++i; i < lines.size() && !starts_with(trim(lines[i]), "```"); ++i) code += lines[i] + "\n";
      ++i;
      out += "<pre><code>" + html_escape(code) + "</code></pre>\n";
    } else if (line.empty()) {
      flush_paragraph();
      ++i;
    } else if (line[0] == '#') {
      flush_paragraph();
      std::size_t level = line.find_first_not_of('#');
      if (level == std::string::npos) level = line.size();
      const int h = int(std::min<std::size_t>(6, level + 2));  // the page's own sections are h1-h2
      out += fmt::format("<h{}>{}</h{}>\n", h, inline_markdown(trim(line.substr(level))), h);
      ++i;
    } else if (line[0] == '|') {
      flush_paragraph();
      std::vector<std::string> block;
      for (; i < lines.size() && starts_with(trim(lines[i]), "|"); ++i) block.push_back(lines[i]);
      out += markdown_table(block);
    } else if (starts_with(line, "- ") || starts_with(line, "* ")) {
      flush_paragraph();
      out += "<ul>\n";
      for (; i < lines.size(); ++i) {
        const std::string item = trim(lines[i]);
        if (!(starts_with(item, "- ") || starts_with(item, "* "))) break;
        out += "<li>" + inline_markdown(item.substr(2)) + "</li>\n";
      }
      out += "</ul>\n";
    } else {
      paragraph += (paragraph.empty() ? "" : " ") + line;
      ++i;
    }
  }
  flush_paragraph();
  return out;
}

namespace {

// ---------------------------------------------------------------- SVG plots

struct PlotSeries {
  std::string name, colour;
  std::vector<std::pair<double, double>> points;
  bool dashed = false;
  bool markers = false;
};

struct PlotOptions {
  std::string title, x_label, y_label;
  bool equal_aspect = false;
  bool log_x = false, log_y = false;
  std::vector<double> x_ticks;  // data values; empty: chosen here
  int width = 560, height = 380;
};

const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"};

std::vector<double> nice_ticks(double lo, double hi, int target = 5) {
  std::vector<double> ticks;
  const double span = hi - lo;
  if (!(span > 0) || !std::isfinite(span)) return {lo};
  const double raw = span / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double norm = raw / magnitude;
  const double step = (norm < 1.5 ? 1 : norm < 3 ? 2 : norm < 7 ? 5 : 10) * magnitude;
  for (double t = std::ceil(lo / step) * step; t <= hi + step * 1e-9 && ticks.size() < 50; t += step)
    ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
  return ticks;
}

std::string tick_label(double value, double step) {
  if (step <= 0 || !std::isfinite(step)) return fmt::format("{:g}", value);
  const int decimals = std::max(0, int(-std::floor(std::log10(step) + 1e-9)));
  return fmt::format("{:.{}f}", value, std::min(decimals, 6));
}

std::string svg_plot(const std::vector<PlotSeries>& series, const PlotOptions& o) {
  const double left = 64, right = 16, top = 30, bottom = 46;
  const double pw = o.width - left - right, ph = o.height - top - bottom;
  auto tx = [&](double x) { return o.log_x ? std::log10(x) : x; };
  auto ty = [&](double y) { return o.log_y ? std::log10(y) : y; };
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : series)
    for (const auto& [x, y] : s.points) {
      if (!std::isfinite(x) || !std::isfinite(y) || (o.log_x && x <= 0) || (o.log_y && y <= 0)) continue;
      x0 = std::min(x0, tx(x)), x1 = std::max(x1, tx(x));
      y0 = std::min(y0, ty(y)), y1 = std::max(y1, ty(y));
    }
  if (!std::isfinite(x0)) return "<p class=\"note\">" + html_escape(o.title) + ": no finite points to plot.</p>";
  auto widen = [](double& a, double& b) {
    const double span = b - a;
    const double pad = span > 0 ? 0.06 * span : std::max(1e-3, 0.1 * std::abs(a));
    a -= pad, b += pad;
  };
  widen(x0, x1);
  widen(y0, y1);
  if (o.equal_aspect) {
    const double scale = std::min(pw / (x1 - x0), ph / (y1 - y0));
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    x0 = cx - 0.5 * pw / scale, x1 = cx + 0.5 * pw / scale;
    y0 = cy - 0.5 * ph / scale, y1 = cy + 0.5 * ph / scale;
  }
  auto px = [&](double x) { return left + (tx(x) - x0) / (x1 - x0) * pw; };
  auto py = [&](double y) { return top + ph - (ty(y) - y0) / (y1 - y0) * ph; };

  // Legend: in the corner of the frame that covers the fewest points of the lines, or right of the
  // frame (the picture made wider) when every corner covers some.
  std::size_t longest = 0;
  for (const auto& s : series) longest = std::max(longest, s.name.size());
  const double lw = 34 + 6.3 * double(longest), lh = 16.0 * double(series.size()) + 4;
  std::vector<std::pair<double, double>> pixels;  // the lines, sampled
  for (const auto& s : series)
    for (std::size_t i = 0; i < s.points.size(); ++i) {
      const auto& [xa, ya] = s.points[i];
      if (!std::isfinite(xa) || !std::isfinite(ya) || (o.log_x && xa <= 0) || (o.log_y && ya <= 0)) continue;
      pixels.push_back({px(xa), py(ya)});
      if (i + 1 < s.points.size()) {
        const auto& [xb, yb] = s.points[i + 1];
        if (!std::isfinite(xb) || !std::isfinite(yb) || (o.log_x && xb <= 0) || (o.log_y && yb <= 0)) continue;
        for (int k = 1; k < 8; ++k)
          pixels.push_back({px(xa) + (px(xb) - px(xa)) * k / 8.0, py(ya) + (py(yb) - py(ya)) * k / 8.0});
      }
    }
  double bx = left + 4, by = top + 4;
  std::size_t fewest = std::numeric_limits<std::size_t>::max();
  for (const auto& [cx, cy] : {std::pair<double, double>{left + 4, top + 4}, {left + pw - lw - 4, top + 4},
                               {left + 4, top + ph - lh - 4}, {left + pw - lw - 4, top + ph - lh - 4}}) {
    std::size_t covered = 0;
    for (const auto& [x, y] : pixels) covered += x >= cx - 3 && x <= cx + lw + 3 && y >= cy - 3 && y <= cy + lh + 3;
    if (covered < fewest) fewest = covered, bx = cx, by = cy;
  }
  int width = o.width;
  if (fewest > 0 && !series.empty()) {
    bx = left + pw + 10, by = top;
    width = int(std::ceil(bx + lw + 8));
  }
  std::string legend_svg;
  if (!series.empty())
    legend_svg += fmt::format(
        "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.0f}\" height=\"{:.0f}\" fill=\"#fff\" fill-opacity=\"0.85\" "
        "stroke=\"#ccc\"/>",
        bx, by, lw, lh);
  double ly = by + 14;
  const double lx = bx + 4;
  for (const auto& s : series) {
    legend_svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" stroke-width=\"2\"{}/>", lx, ly - 4,
        lx + 22, ly - 4, s.colour, s.dashed ? " stroke-dasharray=\"5,3\"" : "");
    legend_svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\">{}</text>", lx + 27, ly,
                              html_escape(s.name));
    ly += 16;
  }

  std::string out = fmt::format(
      "<svg class=\"plot\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" "
      "role=\"img\" aria-label=\"{}\">",
      width, o.height, width, o.height, html_escape(o.title));
  out += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#fff\"/>", width, o.height);
  out += fmt::format("<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">{}</text>",
                     left + pw / 2, html_escape(o.title));
  // Ticks and grid.
  std::vector<std::pair<double, std::string>> xt, yt;  // plot-space value, label
  if (!o.x_ticks.empty()) {
    for (double v : o.x_ticks)
      if (tx(v) >= x0 && tx(v) <= x1) xt.push_back({tx(v), fmt::format("{:g}", v)});
  } else if (o.log_x) {
    for (double e = std::ceil(x0); e <= x1; e += 1) xt.push_back({e, fmt::format("{:g}", std::pow(10.0, e))});
  } else {
    const auto t = nice_ticks(x0, x1);
    const double step = t.size() > 1 ? t[1] - t[0] : 0;
    for (double v : t) xt.push_back({v, tick_label(v, step)});
  }
  if (o.log_y) {
    for (double e = std::ceil(y0); e <= y1; e += 1) yt.push_back({e, fmt::format("{:g}", std::pow(10.0, e))});
  } else {
    const auto t = nice_ticks(y0, y1);
    const double step = t.size() > 1 ? t[1] - t[0] : 0;
    for (double v : t) yt.push_back({v, tick_label(v, step)});
  }
  for (const auto& [v, label] : xt) {
    const double x = left + (v - x0) / (x1 - x0) * pw;
    out += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#e4e4e4\"/>", x, top, x, top + ph);
    out += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\" font-size=\"11\">{}</text>", x,
                       top + ph + 15, html_escape(label));
  }
  for (const auto& [v, label] : yt) {
    const double y = top + ph - (v - y0) / (y1 - y0) * ph;
    out += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#e4e4e4\"/>", left, y, left + pw, y);
    out += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\" font-size=\"11\">{}</text>", left - 5, y + 4,
                       html_escape(label));
  }
  out += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#555\"/>", left, top,
                     pw, ph);
  out += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"12\">{}</text>", left + pw / 2,
                     o.height - 8, html_escape(o.x_label));
  out += fmt::format(
      "<text x=\"14\" y=\"{}\" text-anchor=\"middle\" font-size=\"12\" transform=\"rotate(-90 14 {})\">{}</text>",
      top + ph / 2, top + ph / 2, html_escape(o.y_label));
  // Series.
  for (const auto& s : series) {
    std::string path;
    for (const auto& [x, y] : s.points) {
      if (!std::isfinite(x) || !std::isfinite(y) || (o.log_x && x <= 0) || (o.log_y && y <= 0)) continue;
      path += fmt::format("{:.1f},{:.1f} ", px(x), py(y));
    }
    if (path.empty()) continue;
    out += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.6\"{} points=\"{}\"/>", s.colour,
                       s.dashed ? " stroke-dasharray=\"5,3\"" : "", path);
    if (s.markers)
      for (const auto& [x, y] : s.points)
        if (std::isfinite(x) && std::isfinite(y) && !(o.log_x && x <= 0) && !(o.log_y && y <= 0))
          out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.8\" fill=\"{}\"/>", px(x), py(y), s.colour);
  }
  out += legend_svg + "</svg>";
  return out;
}

// ---------------------------------------------------------------- the page

// The notes that hold the paper's figures ("Paper (Table 3, ...): ..."), from a record or its runs.
std::vector<std::string> paper_notes(const json& record) {
  std::vector<std::string> out;
  auto scan = [&](const json& notes) {
    if (!notes.is_array()) return;
    for (const auto& n : notes)
      if (n.is_string() && starts_with(trim(n.get<std::string>()), "Paper") &&
          std::find(out.begin(), out.end(), n.get<std::string>()) == out.end())
        out.push_back(n.get<std::string>());
  };
  if (record.contains("notes")) scan(record["notes"]);
  if (out.empty() && record.contains("runs") && record["runs"].is_array())
    for (const auto& run : record["runs"])
      if (run.is_object() && run.contains("notes")) scan(run["notes"]);
  return out;
}

// A record's tables from its JSON when its .md is missing: rows and columns in the JSON's (sorted)
// order; plain values or merged cells (mean, 95% interval, n).
std::string json_tables_html(const json& record) {
  std::string out;
  if (!record.contains("tables") || !record["tables"].is_array()) return out;
  for (const auto& t : record["tables"]) {
    if (!t.is_object()) continue;
    const bool merged = t.contains("cells") && t["cells"].is_object();
    const json& body = merged ? t["cells"] : (t.contains("values") ? t["values"] : json::object());
    if (!body.is_object()) continue;
    const bool lower = !t.contains("lower_is_better") || !t["lower_is_better"].is_boolean() ||
                       t["lower_is_better"].get<bool>();
    std::vector<std::string> columns;
    for (const auto& [method, row] : body.items())
      if (row.is_object())
        for (const auto& [column, cell] : row.items())
          if (std::find(columns.begin(), columns.end(), column) == columns.end()) columns.push_back(column);
    auto number = [&](const json& cell) {
      const json& v = merged && cell.is_object() && cell.contains("mean") ? cell["mean"] : cell;
      return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
    };
    std::map<std::string, double> best;
    for (const auto& column : columns)
      for (const auto& [method, row] : body.items())
        if (row.is_object() && row.contains(column)) {
          const double v = number(row[column]);
          if (std::isnan(v)) continue;
          auto it = best.find(column);
          if (it == best.end() || (lower ? v < it->second : v > it->second)) best[column] = v;
        }
    out += "<p><strong>" + html_escape(string_field(t, "title", "(untitled table)")) + "</strong> (" +
           html_escape(string_field(t, "unit", "")) + (merged ? "; mean ± 95% CI (n)" : "") + ")</p>";
    out += "<div class=\"table-wrap\"><table><thead><tr><th>Method</th>";
    for (const auto& c : columns) out += "<th class=\"r\">" + html_escape(c) + "</th>";
    out += "</tr></thead><tbody>";
    for (const auto& [method, row] : body.items()) {
      out += "<tr><td>" + html_escape(method) + "</td>";
      for (const auto& column : columns) {
        std::string text = "-";
        if (row.is_object() && row.contains(column)) {
          const json& cell = row[column];
          const double v = number(cell);
          if (!std::isnan(v)) {
            text = fmt::format("{:.2f}", v);
            if (merged && cell.contains("ci95_high") && cell["ci95_high"].is_number())
              text += fmt::format(" ± {:.2f}", cell["ci95_high"].get<double>() - v);
            if (merged && cell.contains("n")) text += " (" + value_text(cell["n"]) + ")";
            text = html_escape(text);
            if (best.count(column) && v == best[column]) text = "<strong>" + text + "</strong>";
          }
        }
        out += "<td class=\"r\">" + text + "</td>";
      }
      out += "</tr>";
    }
    out += "</tbody></table></div>\n";
  }
  return out;
}

struct TocEntry {
  std::string id, label, kind;
  int depth = 0;
};

class Page {
 public:
  explicit Page(const HtmlReportOptions& options) : options_(options) {}

  std::string build(const std::vector<fs::path>& results) {
    std::string main;
    for (const fs::path& root : results) {
      std::error_code ec;
      if (!fs::exists(root, ec)) throw make_error(root.string(), "", "no such file or folder (--results)");
      const std::string label = root.generic_string();
      std::string html;
      if (fs::is_directory(root, ec)) {
        html = folder(root, label, 0);
      } else {
        html = single_file(root, label);
      }
      if (html.empty()) html = unknown(root, label);
      main += html;
    }
    std::string page = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
                       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>" +
                       html_escape(options_.title) + "</title>\n<style>\n" + stylesheet() + "</style>\n</head>\n<body>\n";
    page += "<header>\n<h1>" + html_escape(options_.title) + "</h1>\n<p class=\"meta\">Made by panoscan " +
            html_escape(project_version()) + " (" + html_escape(source_revision()) + ") on " + html_escape(utc_now()) +
            " from ";
    for (std::size_t i = 0; i < results.size(); ++i)
      page += (i ? ", " : "") + std::string("<code>") + html_escape(results[i].generic_string()) + "</code>";
    page += ". Every image is embedded in this file; plots are drawn from the folders' data.</p>\n</header>\n";
    page += "<nav>\n<h2>Contents</h2>\n<ul>\n";
    for (const auto& t : toc_)
      page += fmt::format("<li class=\"d{}\"><a href=\"#{}\">{}</a> <span class=\"kind\">{}</span></li>\n",
                          std::min(t.depth, 5), t.id, html_escape(t.label), html_escape(t.kind));
    page += "</ul>\n</nav>\n<main>\n" + main + "</main>\n";
    page += "<footer>\n<p class=\"meta\">Page check (by the script below, when the page has loaded):</p>\n"
            "<pre id=\"report-check\">not run (scripts disabled?)</pre>\n</footer>\n";
    page += "<script>\n" + check_script() + "</script>\n</body>\n</html>\n";
    return page;
  }

  int unknown_count() const { return unknown_; }
  int folder_count() const { return int(toc_.size()); }

 private:
  static std::string stylesheet() {
    return R"(body{font-family:"DejaVu Sans",Arial,sans-serif;margin:0;color:#222;background:#f4f4f4;line-height:1.4;font-size:15px}
header,nav,main,footer{max-width:1360px;margin:0 auto;padding:0 18px}
header h1{margin:18px 0 4px;font-size:1.6em}
nav{background:#fff;border:1px solid #ddd;border-radius:6px;padding:6px 18px 10px;margin-top:12px}
nav h2{font-size:1.1em;margin:6px 0}
nav ul{list-style:none;padding:0;margin:0;columns:2;column-gap:32px;font-size:.9em}
nav li{break-inside:avoid}
nav li.d1{padding-left:1.2em}nav li.d2{padding-left:2.4em}nav li.d3{padding-left:3.6em}nav li.d4,nav li.d5{padding-left:4.8em}
section{background:#fff;border:1px solid #ddd;border-radius:6px;padding:10px 18px 14px;margin:16px 0}
section h2{font-size:1.2em;margin:4px 0 2px;word-break:break-all}
h3{font-size:1.02em;margin:12px 0 4px}h4,h5,h6{font-size:1em;margin:10px 0 4px}
.kind{display:inline-block;font-size:.72em;font-weight:normal;padding:1px 7px;border-radius:9px;background:#e3ebf6;color:#234;vertical-align:middle}
.meta{font-size:.86em;color:#444}
.meta code,code{font-size:.92em;background:#f1f1f1;padding:0 3px;border-radius:3px}
.description{margin:2px 0 6px;color:#333}
table{border-collapse:collapse;margin:4px 0 12px;font-size:.88em;background:#fff}
th,td{padding:2px 9px;border-bottom:1px solid #d6d6d6;text-align:left;vertical-align:top}
thead th{border-top:2px solid #333;border-bottom:1.5px solid #333}
tbody tr:last-child td{border-bottom:2px solid #333}
th.r,td.r{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.holds{color:#137333}td.reversed{color:#b3261e;font-weight:bold}td.noise{color:#7a5c00}
table.kv td:first-child{color:#555;white-space:nowrap}
table.kv{font-size:.84em}
table.kv tbody tr:last-child td{border-bottom:1px solid #d6d6d6}
li{font-size:.9em}
section.group{background:none;border:none;border-bottom:2px solid #9aa9bf;border-radius:0;padding:4px 2px;margin:26px 0 6px}
section.group h2{font-size:1.3em;color:#234}
.table-wrap{overflow-x:auto;max-width:100%}
.record{display:flex;flex-wrap:wrap;gap:18px;align-items:flex-start}
.record .tables{flex:1 1 700px;min-width:0}
.record aside{flex:0 1 330px;background:#fff8e1;border-left:4px solid #e0a800;padding:6px 12px;font-size:.86em}
.record aside h3{margin-top:4px}
.gallery{display:flex;flex-wrap:wrap;gap:12px}
figure{margin:4px 0;flex:0 1 calc(50% - 12px);min-width:260px}
.gallery.wide figure{flex-basis:100%}
.gallery.small figure{flex-basis:calc(33% - 12px)}
figure img{width:100%;height:auto;border:1px solid #bbb;display:block;image-rendering:auto}
figure.native img{width:auto;max-width:100%}
figcaption{font-size:.8em;color:#444;margin-top:2px}
svg.plot{max-width:100%;height:auto;border:1px solid #ddd;background:#fff;margin:4px 12px 4px 0}
.note{background:#f3f3f3;border-left:4px solid #888;padding:5px 10px;font-size:.9em;margin:6px 0}
.note.unknown{border-left-color:#b3261e;background:#fdecea}
.settings{font-size:.84em;color:#333}
.settings span{margin-right:14px;display:inline-block}
img.broken{outline:4px solid #d00}
pre{background:#f6f6f6;padding:6px 10px;overflow-x:auto;font-size:.85em}
footer{padding-bottom:30px}
)";
  }

  static std::string check_script() {
    return R"(window.addEventListener('load', function () {
  var images = document.images, loaded = 0;
  for (var i = 0; i < images.length; i++) {
    if (images[i].complete && images[i].naturalWidth > 0) loaded++;
    else images[i].className += ' broken';
  }
  var tables = document.getElementsByTagName('table').length;
  var plots = document.querySelectorAll('svg.plot').length;
  document.getElementById('report-check').textContent =
      'images=' + images.length + ' loaded=' + loaded + ' tables=' + tables + ' plots=' + plots;
});
)";
  }

  std::string add_toc(std::size_t position, const std::string& label, const std::string& kind, int depth) {
    const std::string id = fmt::format("s{}", next_id_++);
    toc_.insert(toc_.begin() + std::ptrdiff_t(std::min(position, toc_.size())), TocEntry{id, label, kind, depth});
    return id;
  }

  std::string section_start(const std::string& id, const std::string& label, const std::string& kind,
                            const std::string& css_class = "") {
    return "<section id=\"" + id + "\"" + (css_class.empty() ? "" : " class=\"" + css_class + "\"") + ">\n<h2>" + html_escape(label) + " <span class=\"kind\">" + html_escape(kind) +
           "</span></h2>\n";
  }

  std::string image(const fs::path& path, const std::string& caption, const std::string& figure_class = "") {
    const auto mime = image_mime(path);
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (!mime || ec) return "";
    if (size > options_.max_image_bytes)
      return "<p class=\"note\">" + html_escape(path.filename().string()) + " (" + megabytes(size) +
             ") is larger than the embedding limit and is not shown.</p>";
    const auto bytes = read_text(path, options_.max_image_bytes);
    if (!bytes) return "<p class=\"note\">" + html_escape(path.filename().string()) + ": cannot be read.</p>";
    return "<figure" + (figure_class.empty() ? "" : " class=\"" + figure_class + "\"") + "><img alt=\"" +
           html_escape(path.filename().string()) + "\" src=\"data:" + *mime + ";base64," + base64(*bytes) +
           "\"><figcaption>" + html_escape(caption) + "</figcaption></figure>\n";
  }

  // "key: value" spans of a flat JSON object (nested objects as compact JSON).
  static void flatten(const std::string& prefix, const json& object, int levels,
                      std::vector<std::pair<std::string, std::string>>& out) {
    for (const auto& [key, value] : object.items()) {
      const std::string name = prefix.empty() ? key : prefix + "." + key;
      if (value.is_object() && levels > 0)
        flatten(name, value, levels - 1, out);
      else
        out.push_back({name, value_text(value)});
    }
  }

  // "key = value" spans of a JSON object (nested objects as dotted keys, three levels).
  static std::string settings_line(const std::string& title, const json& object) {
    if (!object.is_object() || object.empty()) return "";
    std::vector<std::pair<std::string, std::string>> items;
    flatten("", object, 3, items);
    std::string out = "<p class=\"settings\"><strong>" + html_escape(title) + ":</strong> ";
    for (const auto& [key, value] : items) out += "<span>" + html_escape(key) + " = " + html_escape(value) + "</span> ";
    return out + "</p>\n";
  }

  static std::string kv_table(const std::vector<std::pair<std::string, std::string>>& rows) {
    std::string out = "<table class=\"kv\"><tbody>";
    for (const auto& [k, v] : rows) out += "<tr><td>" + html_escape(k) + "</td><td>" + html_escape(v) + "</td></tr>";
    return out + "</tbody></table>\n";
  }

  static std::string provenance(const json& written_by, const std::string& what) {
    if (written_by.is_object() && (written_by.contains("version") || written_by.contains("source_revision")))
      return "panoscan " + value_text(written_by.value("version", json("?"))) + ", source revision " +
             value_text(written_by.value("source_revision", json("?")));
    return "not recorded (" + what + ")";
  }

  // ---- folder kinds

  static bool is_format(const fs::path& file, const std::string& format) {
    const auto j = read_json(file);
    return j && string_field(*j, "format") == format;
  }

  std::string folder(const fs::path& dir, const std::string& label, int depth) {
    if (folders_seen_ >= options_.max_folders) return "";
    const std::size_t toc_position = toc_.size();
    std::string own;
    std::set<std::string> consumed;
    bool leaf = false;  // a scan: its subfolders are its own
    if (fs::exists(dir / "panorama.json") && is_format(dir / "panorama.json", "panoscan-panorama"))
      own += panorama(dir, label, depth);
    if (fs::exists(dir / "rig_estimate.json") && is_format(dir / "rig_estimate.json", "panoscan-rig-trajectory"))
      own += track(dir, label, depth);
    if (fs::exists(dir / "rig.json") && is_format(dir / "rig.json", "panoscan-scan")) {
      own += scan(dir, label, depth);
      leaf = true;
    }
    // Records and evaluations: any JSON with "tables" (+ "table") or a known "kind".
    static const std::set<std::string> known_json = {"panorama.json", "rig_estimate.json", "tracking_stats.json",
                                                     "rig.json", "placement.json"};
    std::vector<std::pair<fs::path, json>> records, evaluations;
    for (const fs::path& file : entries(dir, false)) {
      if (lower(file.extension().string()) != ".json" || known_json.count(file.filename().string())) continue;
      const auto j = read_json(file);
      if (!j) continue;
      if (j->contains("tables") && (*j)["tables"].is_array() && j->contains("table")) records.push_back({file, *j});
      const std::string kind = string_field(*j, "kind");
      if (kind == "cloud_evaluation" || kind == "trajectory_evaluation") evaluations.push_back({file, *j});
    }
    for (std::size_t k = 0; k < records.size(); ++k) {
      own += record(records[k].first, records[k].second, label, depth, k == 0);
      consumed.insert("views");
    }
    // A scene or demo folder: clouds beside the panoramas, or a placement.
    if (!leaf && !fs::exists(dir / "panorama.json")) {
      std::vector<fs::path> clouds;
      for (const fs::path& file : entries(dir, false))
        if (lower(file.extension().string()) == ".ply") clouds.push_back(file);
      if (!clouds.empty() || fs::exists(dir / "placement.json")) own += scene(dir, clouds, evaluations, label, depth);
    }
    for (const auto& [file, j] : evaluations) own += evaluation(file, j, label + "/" + file.filename().string(), depth);
    // The claims of merged records over seeds (`tables merge` writes claims.md beside them).
    if (records.empty() && fs::exists(dir / "claims.md"))
      if (const auto claims = read_text(dir / "claims.md")) {
        const std::string id = add_toc(toc_.size(), label + "/claims.md", "claims over seeds", depth);
        own += section_start(id, label + "/claims.md", "claims over seeds") + markdown_to_html(*claims) + "</section>\n";
      }
    if (!own.empty()) ++folders_seen_;
    std::string children;
    std::vector<std::string> unrecognised;
    int recognised = 0;
    if (!leaf && depth < options_.max_depth) {
      for (const fs::path& sub : entries(dir, true)) {
        const std::string name = sub.filename().string();
        if (consumed.count(name)) continue;
        const std::string html = folder(sub, label + "/" + name, depth + 1);
        if (html.empty()) {
          unrecognised.push_back(name);
        } else {
          children += html;
          ++recognised;
        }
      }
    }
    if (own.empty() && children.empty()) return "";
    std::string note;
    if (!unrecognised.empty()) {
      std::string names;
      for (std::size_t i = 0; i < unrecognised.size() && i < 12; ++i) names += (i ? ", " : "") + unrecognised[i];
      if (unrecognised.size() > 12) names += fmt::format(" and {} more", unrecognised.size() - 12);
      note = "<p class=\"note\">Also in this folder, not recognised as results: " + html_escape(names) + ".</p>\n";
    }
    if (own.empty()) {
      if (recognised == 1 && note.empty() && depth > 0) {
        // A folder that only holds one result folder (runs/seed1/table4): no heading of its own.
        for (std::size_t i = toc_position; i < toc_.size(); ++i) toc_[i].depth = std::max(0, toc_[i].depth - 1);
        return children;
      }
      // A folder of results: a heading, then its results.
      const std::string kind = fmt::format("folder of {} result folders", recognised);
      const std::string id = add_toc(toc_position, label, kind, depth);
      return section_start(id, label, kind, "group") + note + "</section>\n" + children;
    }
    if (!note.empty()) own += "<section class=\"aside\">" + note + "</section>\n";
    return own + children;
  }

  std::string single_file(const fs::path& file, const std::string& label) {
    const auto j = read_json(file);
    if (!j) return "";
    if (j->contains("tables") && (*j)["tables"].is_array() && j->contains("table")) return record(file, *j, label, 0, true);
    const std::string kind = string_field(*j, "kind");
    if (kind == "cloud_evaluation" || kind == "trajectory_evaluation") return evaluation(file, *j, label, 0);
    return "";
  }

  std::string unknown(const fs::path& path, const std::string& label) {
    ++unknown_;
    const std::string id = add_toc(toc_.size(), label, "not recognised", 0);
    std::string out = section_start(id, label, "not recognised");
    out += "<p class=\"note unknown\">Not a result PanoScan knows: no table record (&lt;name&gt;.json with tables), "
           "panorama (panorama.json), track folder (rig_estimate.json), scan (rig.json), evaluation "
           "(<code>eval --json</code>) or scene (clouds, placement.json) found here or " +
           std::to_string(options_.max_depth) + " levels below.";
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      std::vector<fs::path> items = entries(path, true), files = entries(path, false);
      items.insert(items.end(), files.begin(), files.end());
      std::string names;
      for (std::size_t i = 0; i < items.size() && i < 15; ++i)
        names += (i ? ", " : "") + items[i].filename().string() + (fs::is_directory(items[i], ec) ? "/" : "");
      if (items.size() > 15) names += fmt::format(" and {} more", items.size() - 15);
      out += " It holds: " + html_escape(items.empty() ? std::string("nothing") : names) + ".";
    }
    return out + "</p>\n</section>\n";
  }

  std::string record(const fs::path& file, const json& j, const std::string& label, int depth, bool with_images) {
    const fs::path dir = file.parent_path();
    const std::string name = string_field(j, "table", file.stem().string());
    const bool merged = j.value("merged", false);
    const std::string kind = merged ? "table record, merged over seeds" : "table record";
    const std::string shown = label + (dir.filename().string() == name ? "" : " (" + name + ")");
    const std::string id = add_toc(toc_.size(), shown, kind, depth);
    std::string out = section_start(id, shown, kind);
    if (j.contains("description")) out += "<p class=\"description\">" + html_escape(value_text(j["description"])) + "</p>\n";
    // Provenance and settings.
    std::vector<std::pair<std::string, std::string>> rows;
    rows.push_back({"version", j.contains("version") ? value_text(j["version"]) : "not recorded in the record"});
    rows.push_back({"source revision", j.contains("source_revision") ? value_text(j["source_revision"]) : "not recorded"});
    if (j.contains("date_utc")) rows.push_back({"date (UTC)", value_text(j["date_utc"])});
    if (j.contains("machine") && j["machine"].is_object()) {
      std::string machine = string_field(j["machine"], "cpu", "?");
      if (j["machine"].contains("hardware_threads"))
        machine += ", " + value_text(j["machine"]["hardware_threads"]) + " hardware threads";
      rows.push_back({"machine", machine});
    }
    if (j.contains("seconds") && j["seconds"].is_number())
      rows.push_back({"run time", fmt::format("{:.0f} s", j["seconds"].get<double>())});
    if (merged) {
      if (j.contains("seeds")) rows.push_back({"seeds", value_text(j["seeds"])});
      for (const char* key : {"size", "noise", "scene_texture"})
        if (j.contains(key)) rows.push_back({key, value_text(j[key])});
      if (j.contains("runs") && j["runs"].is_array()) rows.push_back({"runs merged", std::to_string(j["runs"].size())});
    }
    if (j.contains("scans_rendered_by") && j["scans_rendered_by"].is_object()) {
      std::set<std::string> revisions;
      for (const auto& [scan_key, revision] : j["scans_rendered_by"].items()) revisions.insert(value_text(revision));
      std::string text = fmt::format("{} scan(s), rendered by ", j["scans_rendered_by"].size());
      std::size_t i = 0;
      for (const auto& r : revisions) text += (i++ ? ", " : "") + r;
      rows.push_back({"scans", text});
    }
    out += kv_table(rows);
    if (j.contains("settings")) out += settings_line("settings", j["settings"]);
    if (j.contains("driver_settings")) out += settings_line("driver settings", j["driver_settings"]);
    if (merged && j.contains("statistics")) out += "<p class=\"settings\">" + html_escape(value_text(j["statistics"])) + "</p>\n";
    // Tables (the driver's Markdown: its row order, digits and bold best values) beside the paper.
    const auto markdown = read_text(dir / (file.stem().string() + ".md"));
    out += "<div class=\"record\"><div class=\"tables\">\n";
    if (markdown) {
      out += markdown_to_html(*markdown);
    } else {
      out += "<p class=\"note\">No " + html_escape(file.stem().string()) +
             ".md beside the record: the tables below are drawn from the JSON (rows in its alphabetical order).</p>\n" +
             json_tables_html(j);
    }
    out += "</div>\n<aside>\n<h3>The paper's figures</h3>\n";
    const auto paper = paper_notes(j);
    if (paper.empty()) {
      out += "<p>This record carries no figures of the paper.</p>\n";
    } else {
      for (const auto& p : paper) out += "<p>" + html_escape(p) + "</p>\n";
      out += "<p class=\"meta\">As the record's note gives them: the records hold the paper's figures as text, not "
             "per cell, so they are shown as written, beside ours.</p>\n";
    }
    out += "</aside>\n</div>\n";
    if (with_images) {
      std::string figures;
      for (const fs::path& f : entries(dir, false))
        if (image_mime(f)) figures += image(f, f.filename().string(), "native");
      if (!figures.empty()) out += "<div class=\"gallery\">\n" + figures + "</div>\n";
      if (name == "fig8" && !fs::exists(dir / "fig8.png") && fs::exists(dir / "fig8_sweep.csv"))
        out += fig8_plots(dir / "fig8_sweep.csv");
      if (fs::is_directory(dir / "views")) {
        std::string views;
        for (const fs::path& f : entries(dir / "views", false))
          if (image_mime(f)) views += image(f, "views/" + f.filename().string());
        if (!views.empty()) {
          out += "<h3>Error-coloured views</h3>\n";
          // The drivers' notes on the views ("Views of SO-1 (views/): ..."), for the scans shown.
          if (j.contains("notes") && j["notes"].is_array())
            for (const auto& n : j["notes"]) {
              if (!n.is_string() || !starts_with(n.get<std::string>(), "Views of ")) continue;
              const std::string text = n.get<std::string>();
              const std::string scan_label = text.substr(9, text.find(' ', 9) - 9);
              bool shown = false;
              for (const fs::path& f : entries(dir / "views", false))
                shown = shown || starts_with(f.filename().string(), scan_label + "_");
              if (shown) out += "<p class=\"meta\">" + html_escape(text) + "</p>\n";
            }
          out += "<div class=\"gallery\">\n" + views + "</div>\n";
        }
      }
    }
    return out + "</section>\n";
  }

  std::string fig8_plots(const fs::path& csv_path) {
    const auto text = read_text(csv_path);
    if (!text) return "";
    std::istringstream in(*text);
    std::string line;
    std::vector<std::string> header;
    std::map<std::string, std::vector<std::map<std::string, double>>> by_scan;
    std::set<double> ns;
    while (std::getline(in, line)) {
      std::vector<std::string> cells;
      std::stringstream row(line);
      std::string cell;
      while (std::getline(row, cell, ',')) cells.push_back(trim(cell));
      if (cells.empty()) continue;
      if (header.empty()) {
        header = cells;
        continue;
      }
      std::map<std::string, double> values;
      for (std::size_t k = 1; k < cells.size() && k < header.size(); ++k) {
        try {
          values[header[k]] = std::stod(cells[k]);
        } catch (const std::exception&) {
        }
      }
      if (values.count("n")) ns.insert(values["n"]);
      by_scan[cells[0]].push_back(values);
    }
    std::vector<PlotSeries> accuracy, time;
    int colour = 0;
    for (const auto& [scan_name, rows] : by_scan) {
      PlotSeries rmse{scan_name + " stitched RMSE", kPalette[colour % 7], {}, false, true};
      PlotSeries ate{scan_name + " ATE", kPalette[colour % 7], {}, true, true};
      PlotSeries opt{scan_name + " optimisation", kPalette[colour % 7], {}, false, true};
      for (const auto& r : rows) {
        auto get = [&](const char* key) { return r.count(key) ? r.at(key) : std::numeric_limits<double>::quiet_NaN(); };
        rmse.points.push_back({get("n"), get("stitched_rmse_mm")});
        ate.points.push_back({get("n"), get("ate_mm")});
        opt.points.push_back({get("n"), get("optimisation_s")});
      }
      accuracy.push_back(rmse);
      accuracy.push_back(ate);
      time.push_back(opt);
      ++colour;
    }
    PlotOptions a;
    a.title = "Fig. 8: tracking error against n";
    a.x_label = "n (one frame of every n per camera)";
    a.y_label = "mm";
    a.log_x = true;
    a.x_ticks.assign(ns.begin(), ns.end());
    PlotOptions t = a;
    t.title = "Fig. 8: optimisation time against n";
    t.y_label = "s (log)";
    t.log_y = true;
    return "<p class=\"meta\">Plotted from fig8_sweep.csv (no fig8.png beside it).</p>\n" + svg_plot(accuracy, a) +
           svg_plot(time, t) + "\n";
  }

  std::string panorama(const fs::path& dir, const std::string& label, int depth) {
    const json j = *read_json(dir / "panorama.json");
    const std::string id = add_toc(toc_.size(), label, "panorama", depth);
    std::string out = section_start(id, label, "panorama");
    std::vector<std::pair<std::string, std::string>> rows;
    rows.push_back({"written by", provenance(j.value("written_by", json()),
                                             "panorama.json has no written_by: written before it was recorded")});
    rows.push_back({"size", value_text(j.value("width", json())) + " x " + value_text(j.value("height", json()))});
    rows.push_back({"method", value_text(j.value("method", json())) + ", lambda " + value_text(j.value("lambda", json()))});
    if (j.contains("world_from_pano") && j["world_from_pano"].contains("translation"))
      rows.push_back({"centre (world)", point_text(j["world_from_pano"]["translation"])});
    if (j.contains("energy") && j["energy"].is_array() && !j["energy"].empty()) {
      const json& first = j["energy"].front();
      const json& last = j["energy"].back();
      rows.push_back({"fusion energy", fmt::format("{} iterations, {} -> {}", j["energy"].size(),
                                                   value_text(first.value("smoothed", json())),
                                                   value_text(last.value("smoothed", json())))});
    }
    if (fs::exists(dir / "cloud.ply"))
      rows.push_back({"cloud.ply", fmt::format("{} points (world frame; a PLY, not drawn here)", ply_vertex_count(dir / "cloud.ply"))});
    out += kv_table(rows);
    const json legend = j.value("legend", json::object());
    auto range = [&](const char* key, double scale, const char* unit) -> std::string {
      if (!legend.contains(key) || !legend[key].is_array() || legend[key].size() != 2) return "";
      return fmt::format(", {:.3g} to {:.3g} {}", legend[key][0].get<double>() * scale,
                         legend[key][1].get<double>() * scale, unit);
    };
    std::string figures;
    if (fs::exists(dir / "colour.png")) figures += image(dir / "colour.png", "colour.png: colour");
    if (fs::exists(dir / "depth.png"))
      figures += image(dir / "depth.png", "depth.png: radial depth" + range("depth_png_m", 1.0, "m"));
    if (fs::exists(dir / "variance.png"))
      figures += image(dir / "variance.png", "variance.png: sigma_z" + range("variance_png_sigma_m", 1e3, "mm"));
    if (fs::exists(dir / "flags.png"))
      figures += image(dir / "flags.png", "flags.png: white = sigma_z above the limit (left out of registration)");
    out += "<div class=\"gallery\">\n" + figures + "</div>\n";
    if (legend.contains("colours")) out += "<p class=\"meta\">Colour scale: " + html_escape(value_text(legend["colours"])) + ".</p>\n";
    return out + "</section>\n";
  }

  // The TUM trajectories of a folder: camK.txt (sorted), each read or skipped with a note.
  static std::vector<std::pair<std::string, std::vector<StampedPose>>> trajectories(const fs::path& dir,
                                                                                    std::string& notes) {
    std::vector<std::pair<std::string, std::vector<StampedPose>>> out;
    for (const fs::path& f : entries(dir, false)) {
      if (f.extension() != ".txt" || !starts_with(f.filename().string(), "cam")) continue;
      try {
        out.push_back({f.stem().string(), read_tum_trajectory(f)});
      } catch (const std::exception& e) {
        notes += "<p class=\"note\">" + html_escape(e.what()) + "</p>\n";
      }
    }
    return out;
  }

  // The scan a track folder belongs to: tracking_stats.json's "scan", else a sibling named like the
  // folder without "-poses" (recon scene, demo), when it has ground truth.
  static std::optional<fs::path> scan_of_track(const fs::path& dir, const json& stats, const json& estimate) {
    std::vector<fs::path> candidates;
    for (const json* j : {&stats, &estimate})
      if (j->contains("scan") && (*j)["scan"].is_string()) {
        const fs::path p = (*j)["scan"].get<std::string>();
        candidates.push_back(p.is_absolute() ? p : dir / p);
      }
    const std::string name = dir.filename().string();
    const std::string suffix = "-poses";
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
      candidates.push_back(dir.parent_path() / name.substr(0, name.size() - suffix.size()));
    for (const fs::path& c : candidates)
      if (fs::is_directory(c / "groundtruth")) return c;
    return std::nullopt;
  }

  std::string track(const fs::path& dir, const std::string& label, int depth) {
    const json estimate = *read_json(dir / "rig_estimate.json");
    const json stats = read_json(dir / "tracking_stats.json").value_or(json::object());
    const std::string id = add_toc(toc_.size(), label, "track (rig trajectory)", depth);
    std::string out = section_start(id, label, "track (rig trajectory)");
    std::vector<std::pair<std::string, std::string>> rows;
    rows.push_back({"written by", provenance(stats.value("written_by", estimate.value("written_by", json())),
                                             stats.empty() ? "no tracking_stats.json"
                                                           : "tracking_stats.json has no written_by: written before it was recorded")});
    rows.push_back({"source", value_text(estimate.value("source", json("?")))});
    if (!stats.empty()) {
      for (const char* key : {"mode", "frames", "landmarks", "observations", "iterations", "threads"})
        if (stats.contains(key)) rows.push_back({key, value_text(stats[key])});
      if (stats.contains("initial_cost") && stats.contains("final_cost"))
        rows.push_back({"cost", value_text(stats["initial_cost"]) + " -> " + value_text(stats["final_cost"]) +
                                    (stats.value("converged", false) ? " (converged)" : " (NOT converged)")});
      if (stats.contains("verdict") && stats["verdict"].is_object()) {
        const json& v = stats["verdict"];
        const bool reliable = v.value("reliable", false);
        rows.push_back({"self-check", reliable ? "reliable" : "UNRELIABLE: " + value_text(v.value("first_failure", json("")))});
      }
      if (stats.contains("seconds") && stats["seconds"].is_object()) {
        std::string t;
        for (const char* key : {"frontend", "solve"})
          if (stats["seconds"].contains(key) && stats["seconds"][key].is_number())
            t += fmt::format("{}{} {:.2f} s", t.empty() ? "" : ", ", key, stats["seconds"][key].get<double>());
        if (!t.empty()) rows.push_back({"time", t});
      }
    } else {
      rows.push_back({"tracking_stats.json", "absent (a trajectory folder written by recon scene or the demo)"});
    }
    std::string notes;
    const auto estimated = trajectories(dir, notes);
    const auto scan_dir = scan_of_track(dir, stats, estimate);
    rows.push_back({"scan", scan_dir ? scan_dir->string() : "not found (no ground truth to compare with)"});
    out += kv_table(rows) + notes;
    // The plot: with ground truth in the scene frame (the estimate put onto it by the reference
    // camera's first pose), else in the rotation-axis frame (z = the axis).
    std::vector<PlotSeries> series;
    PlotOptions o;
    o.equal_aspect = true;
    o.x_label = "x (m)";
    o.y_label = "y (m)";
    std::string caption;
    if (scan_dir) {
      std::string gt_notes;
      const auto truth = trajectories(*scan_dir / "groundtruth", gt_notes);
      int reference = 0;
      if (const auto rig = read_json(*scan_dir / "rig.json"); rig && rig->contains("reference_sensor") &&
                                                             (*rig)["reference_sensor"].is_number_integer())
        reference = (*rig)["reference_sensor"].get<int>();
      std::optional<Rigid3d> scene_from_est;
      if (reference >= 0 && std::size_t(reference) < estimated.size()) {
        for (const auto& [name, poses] : truth)
          if (name == estimated[reference].first && !poses.empty() && !estimated[reference].second.empty())
            scene_from_est = scene_from_reconstruction(poses, estimated[reference].second);
      }
      if (scene_from_est) {
        int colour = 0;
        for (const auto& [name, poses] : estimated) {
          PlotSeries est{name + " estimate", kPalette[colour % 7], {}};
          for (const auto& p : poses) {
            const Eigen::Vector3d c = *scene_from_est * p.world_from_cam.translation();
            est.points.push_back({c.x(), c.y()});
          }
          for (const auto& [truth_name, truth_poses] : truth)
            if (truth_name == name) {
              PlotSeries gt{name + " ground truth", kPalette[colour % 7], {}, true};
              for (const auto& p : truth_poses) gt.points.push_back({p.world_from_cam.translation().x(), p.world_from_cam.translation().y()});
              series.push_back(gt);
            }
          series.push_back(est);
          ++colour;
        }
        o.title = "Camera centres, top view (scene frame)";
        caption = "Top view (x-y, scene frame) of each camera's centres: dashed the ground truth of " +
                  scan_dir->filename().string() + ", solid the estimate, put onto it by the reference camera's first pose.";
      }
    }
    if (series.empty()) {
      Rigid3d axis_from_world = Rigid3d::Identity();
      bool have_axis = false;
      if (estimate.contains("world_from_axis")) {
        try {
          axis_from_world = pose_from_json(estimate["world_from_axis"], (dir / "rig_estimate.json").string(), "world_from_axis").inverse();
          have_axis = true;
        } catch (const std::exception&) {
        }
      }
      int colour = 0;
      for (const auto& [name, poses] : estimated) {
        PlotSeries est{name + " estimate", kPalette[colour++ % 7], {}};
        for (const auto& p : poses) {
          const Eigen::Vector3d c = axis_from_world * p.world_from_cam.translation();
          est.points.push_back({c.x(), c.y()});
        }
        series.push_back(est);
      }
      o.title = have_axis ? "Camera centres, top view (rotation-axis frame)" : "Camera centres (x-y, tracking frame)";
      caption = std::string(have_axis ? "Top view (x-y with z the estimated rotation axis) of each camera's estimated centres"
                                      : "Each camera's estimated centres, x-y of the tracking frame") +
                "; no ground truth: the folder names no scan with groundtruth/.";
    }
    if (!series.empty()) out += svg_plot(series, o) + "<p class=\"meta\">" + html_escape(caption) + "</p>\n";
    return out + "</section>\n";
  }

  std::string scan(const fs::path& dir, const std::string& label, int depth) {
    const json rig = *read_json(dir / "rig.json");
    const std::string id = add_toc(toc_.size(), label, "scan", depth);
    std::string out = section_start(id, label, "scan");
    std::vector<std::pair<std::string, std::string>> rows;
    const auto truth = read_json(dir / "groundtruth" / "rig_truth.json");
    const auto imported = read_json(dir / "import.json");
    if (truth && truth->contains("rendered_by")) {
      rows.push_back({"rendered by", provenance((*truth)["rendered_by"], "")});
      if ((*truth)["rendered_by"].contains("ray_tracer"))
        rows.push_back({"ray tracer", value_text((*truth)["rendered_by"]["ray_tracer"])});
    } else if (imported) {
      json w = {{"version", imported->value("panoscan_version", json("?"))},
                {"source_revision", imported->value("source_revision", json("?"))}};
      rows.push_back({"imported by", provenance(w, "")});
    } else {
      rows.push_back({"written by", "not recorded (no groundtruth/rig_truth.json or import.json)"});
    }
    rows.push_back({"description", value_text(rig.value("description", json("")))});
    rows.push_back({"motion", value_text(rig.value("motion", json("rotator")))});
    std::vector<std::string> sensors;
    std::string frames_text;
    if (rig.contains("sensors") && rig["sensors"].is_array())
      for (const auto& s : rig["sensors"]) {
        const std::string name = string_field(s, "name", "?");
        sensors.push_back(name);
        int frames = 0;
        if (const auto listing = read_text(dir / name / "rgb.txt")) {
          std::istringstream in(*listing);
          std::string line;
          while (std::getline(in, line))
            if (!trim(line).empty() && trim(line)[0] != '#') ++frames;
        }
        frames_text += fmt::format("{}{}: {} frames at {}x{}", frames_text.empty() ? "" : "; ", name, frames,
                                   value_text(s.value("width", json())), value_text(s.value("height", json())));
      }
    rows.push_back({"cameras", frames_text});
    rows.push_back({"reference camera", value_text(rig.value("reference_sensor", json(0)))});
    rows.push_back({"ground truth", fs::is_directory(dir / "groundtruth") ? "groundtruth/ (mesh, trajectories)" : "none"});
    out += kv_table(rows);
    // The first colour frame of each camera.
    std::string figures;
    for (const std::string& name : sensors) {
      const auto listing = read_text(dir / name / "rgb.txt");
      if (!listing) continue;
      std::istringstream in(*listing);
      std::string line;
      while (std::getline(in, line)) {
        line = trim(line);
        if (line.empty() || line[0] == '#') continue;
        std::istringstream fields(line);
        std::string stamp, file;
        fields >> stamp >> file;
        if (!file.empty()) figures += image(dir / name / file, name + ", first frame (t = " + stamp + " s)");
        break;
      }
    }
    if (!figures.empty()) out += "<div class=\"gallery small\">\n" + figures + "</div>\n";
    if (fs::is_directory(dir / "groundtruth")) {
      std::string notes;
      const auto truth_poses = trajectories(dir / "groundtruth", notes);
      std::vector<PlotSeries> series;
      int colour = 0;
      for (const auto& [name, poses] : truth_poses) {
        PlotSeries s{name + " ground truth", kPalette[colour++ % 7], {}, true};
        for (const auto& p : poses) s.points.push_back({p.world_from_cam.translation().x(), p.world_from_cam.translation().y()});
        series.push_back(s);
      }
      PlotOptions o;
      o.title = "Ground-truth camera centres, top view (scene frame)";
      o.x_label = "x (m)";
      o.y_label = "y (m)";
      o.equal_aspect = true;
      if (!series.empty()) out += notes + svg_plot(series, o) + "\n";
    }
    return out + "</section>\n";
  }

  std::string evaluation(const fs::path& file, const json& j, const std::string& label, int depth) {
    const std::string kind = string_field(j, "kind") == "cloud_evaluation" ? "cloud evaluation" : "trajectory evaluation";
    const std::string id = add_toc(toc_.size(), label, kind, depth);
    std::string out = section_start(id, label, kind);
    std::vector<std::pair<std::string, std::string>> rows;
    json written = {{"version", j.value("panoscan_version", json("?"))}, {"source_revision", j.value("source_revision", json("?"))}};
    rows.push_back({"written by", provenance(written, "")});
    if (j.contains("inputs") && j["inputs"].is_object())
      for (const auto& [key, value] : j["inputs"].items())
        if (!value.is_object()) rows.push_back({key, value_text(value)});
    out += kv_table(rows);
    auto stats_row = [](const std::string& name, const json& s) {
      std::string r = "<tr><td>" + html_escape(name) + "</td><td class=\"r\">" +
                      html_escape(s.contains("count") ? value_text(s["count"]) : "-") + "</td>";
      for (const char* key : {"rmse_m", "mean_m", "median_m", "p90_m", "max_m"})
        r += "<td class=\"r\">" +
             html_escape(s.contains(key) && s[key].is_number() ? fmt::format("{:.3f}", 1e3 * s[key].get<double>()) : "-") +
             "</td>";
      return r + "</tr>";
    };
    std::string stats = "<div class=\"table-wrap\"><table><thead><tr><th>distance</th><th class=\"r\">count</th><th "
                        "class=\"r\">RMSE (mm)</th><th class=\"r\">mean (mm)</th><th class=\"r\">median (mm)</th><th "
                        "class=\"r\">p90 (mm)</th><th class=\"r\">max (mm)</th></tr></thead><tbody>";
    bool any = false;
    if (j.contains("accuracy") && j["accuracy"].is_object()) stats += stats_row("accuracy", j["accuracy"]), any = true;
    if (j.contains("accuracy_within_cutoff") && j["accuracy_within_cutoff"].is_object() &&
        j["accuracy_within_cutoff"].contains("stats"))
      stats += stats_row("accuracy within the cut-off", j["accuracy_within_cutoff"]["stats"]), any = true;
    if (j.contains("completeness") && j["completeness"].is_object() && j["completeness"].contains("stats"))
      stats += stats_row("completeness", j["completeness"]["stats"]), any = true;
    if (j.contains("ate") && j["ate"].is_object()) stats += stats_row("ATE (after alignment)", j["ate"]), any = true;
    if (j.contains("rpe") && j["rpe"].is_object() && j["rpe"].contains("translation"))
      stats += stats_row(fmt::format("RPE translation over {} s", value_text(j["rpe"].value("delta_s", json("?")))),
                         j["rpe"]["translation"]),
          any = true;
    stats += "</tbody></table></div>\n";
    if (any) out += stats;
    if (j.contains("scores") && j["scores"].is_array() && !j["scores"].empty()) {
      out += "<div class=\"table-wrap\"><table><thead><tr><th class=\"r\">threshold (mm)</th><th class=\"r\">accuracy "
             "(%)</th><th class=\"r\">completeness (%)</th><th class=\"r\">F-score (%)</th></tr></thead><tbody>";
      for (const auto& s : j["scores"]) {
        auto pct = [&](const char* key) {
          return s.contains(key) && s[key].is_number() ? fmt::format("{:.1f}", 100.0 * s[key].get<double>()) : "-";
        };
        out += "<tr><td class=\"r\">" +
               html_escape(s.contains("threshold_m") && s["threshold_m"].is_number()
                               ? fmt::format("{:.1f}", 1e3 * s["threshold_m"].get<double>())
                               : "-") +
               "</td><td class=\"r\">" + pct("accuracy") + "</td><td class=\"r\">" + pct("completeness") +
               "</td><td class=\"r\">" + pct("f_score") + "</td></tr>";
      }
      out += "</tbody></table></div>\n";
    }
    if (j.contains("ate_rotation") && j["ate_rotation"].is_object())
      out += settings_line("ATE rotation", j["ate_rotation"]);
    if (j.contains("rpe") && j["rpe"].is_object() && j["rpe"].contains("rotation"))
      out += settings_line("RPE rotation", j["rpe"]["rotation"]);
    // The matched positions (TUM ATE): ground truth and the aligned estimate, top view.
    if (j.contains("matched") && j["matched"].is_object()) {
      PlotSeries gt{"ground truth", kPalette[0], {}, true}, est{"estimate (aligned)", kPalette[1], {}};
      auto fill = [](const json& list, PlotSeries& series) {
        if (!list.is_array()) return;
        for (const auto& p : list)
          if (p.is_array() && p.size() >= 2 && p[0].is_number() && p[1].is_number())
            series.points.push_back({p[0].get<double>(), p[1].get<double>()});
      };
      fill(j["matched"].value("gt_positions", json()), gt);
      fill(j["matched"].value("est_positions_aligned", json()), est);
      if (!gt.points.empty() || !est.points.empty()) {
        PlotOptions o;
        o.title = "Matched positions, top view (ground-truth frame)";
        o.x_label = "x (m)";
        o.y_label = "y (m)";
        o.equal_aspect = true;
        out += svg_plot({gt, est}, o) + "\n";
      }
    }
    if (j.contains("coloured_ply") && j["coloured_ply"].is_object())
      out += "<p class=\"note\">Error-coloured cloud: <code>" + html_escape(value_text(j["coloured_ply"].value("path", json("?")))) +
             "</code> (" + html_escape(value_text(j["coloured_ply"].value("colour_map", json("?")))) + ", range " +
             html_escape(value_text(j["coloured_ply"].value("range_m", json()))) +
             " m): a PLY, for a point-cloud viewer; not drawn here.</p>\n";
    if (j.contains("settings")) out += settings_line("settings", j["settings"]);
    return out + "</section>\n";
  }

  std::string scene(const fs::path& dir, const std::vector<fs::path>& clouds,
                    const std::vector<std::pair<fs::path, json>>& evaluations, const std::string& label, int depth) {
    const std::string id = add_toc(toc_.size(), label, "scene", depth);
    std::string out = section_start(id, label, "scene");
    std::set<std::string> coloured;
    for (const auto& [file, j] : evaluations)
      if (j.contains("coloured_ply") && j["coloured_ply"].is_object() && j["coloured_ply"].contains("path"))
        coloured.insert(fs::path(value_text(j["coloured_ply"]["path"])).filename().string());
    if (!clouds.empty()) {
      out += "<div class=\"table-wrap\"><table><thead><tr><th>cloud</th><th class=\"r\">points</th><th "
             "class=\"r\">size</th><th>note</th></tr></thead><tbody>";
      for (const fs::path& c : clouds) {
        std::error_code ec;
        const auto size = fs::file_size(c, ec);
        const long long n = ply_vertex_count(c);
        out += "<tr><td><code>" + html_escape(c.filename().string()) + "</code></td><td class=\"r\">" +
               (n >= 0 ? std::to_string(n) : std::string("?")) + "</td><td class=\"r\">" + megabytes(ec ? 0 : size) +
               "</td><td>" + (coloured.count(c.filename().string()) ? "error-coloured (eval cloud)" : "") + "</td></tr>";
      }
      out += "</tbody></table></div>\n<p class=\"meta\">Point clouds are PLY files for a point-cloud viewer; the page "
             "does not draw them.</p>\n";
    }
    if (const auto placement = read_json(dir / "placement.json")) {
      std::vector<std::pair<std::string, std::string>> rows;
      if (placement->contains("panoramas") && (*placement)["panoramas"].is_array())
        for (const auto& p : (*placement)["panoramas"])
          rows.push_back({"panorama " + string_field(p, "name", "?"),
                          "centre " + point_text(p.contains("world_from_panorama") && p["world_from_panorama"].contains("translation")
                                                     ? p["world_from_panorama"]["translation"]
                                                     : json())});
      if (placement->contains("registrations") && (*placement)["registrations"].is_array())
        for (const auto& r : (*placement)["registrations"])
          rows.push_back({"registration", string_field(r, "source", "?") + " -> " + string_field(r, "target", "?") +
                                              (r.value("kept", false) ? ", kept" : ", dropped")});
      rows.push_back({"pose graph", placement->value("pose_graph_used", false) ? "used" : "not used"});
      out += "<h3>Placement (placement.json)</h3>\n" + kv_table(rows);
    }
    return out + "</section>\n";
  }

  const HtmlReportOptions& options_;
  std::vector<TocEntry> toc_;
  int next_id_ = 0;
  int unknown_ = 0;
  int folders_seen_ = 0;
};

int count_of(const std::string& text, const std::string& needle) {
  int n = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + needle.size())) ++n;
  return n;
}

}  // namespace

std::string html_report(const std::vector<fs::path>& results, const HtmlReportOptions& options,
                        HtmlReportSummary* summary) {
  if (results.empty()) throw make_error("report", "--results", "give at least one results folder");
  Page page(options);
  std::string html = page.build(results);
  if (summary) {
    summary->folders = page.folder_count();
    summary->unknown = page.unknown_count();
    summary->images = count_of(html, "<img ");
    summary->tables = count_of(html, "<table");
    summary->plots = count_of(html, "<svg class=\"plot\"");
    summary->bytes = html.size();
  }
  return html;
}

HtmlReportSummary write_html_report(const std::vector<fs::path>& results, const fs::path& out,
                                    const HtmlReportOptions& options) {
  HtmlReportSummary summary;
  const std::string html = html_report(results, options, &summary);
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  write_file_atomic(out, html);
  return summary;
}

}  // namespace panoscan::eval
