#include "lrf/eval/report.h"

#include <algorithm>
#include <cmath>
#include <ctime>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/run_info.h"

namespace lrf {
namespace {

// Inline style: system fonts, tabular figures for numbers, a grid of images that wraps on narrow
// screens, and a dark variant for readers whose system asks for it.
const char* kCss = R"css(
:root { --fg: #1f2328; --muted: #59636e; --line: #d1d9e0; --bg: #ffffff; --panel: #f6f8fa; --accent: #0969da; }
@media (prefers-color-scheme: dark) {
  :root { --fg: #e6edf3; --muted: #9198a1; --line: #3d444d; --bg: #0d1117; --panel: #151b23; --accent: #4493f8; }
}
* { box-sizing: border-box; }
body { margin: 0; background: var(--bg); color: var(--fg);
       font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 1440px; margin: 0 auto; padding: 24px 20px 48px; }
h1 { font-size: 1.7rem; margin: 0 0 20px; }
h2 { font-size: 1.2rem; margin: 36px 0 12px; padding-bottom: 4px; border-bottom: 1px solid var(--line); }
h3 { font-size: 1rem; margin: 28px 0 10px; font-family: ui-monospace, SFMono-Regular, Menlo, Consolas, monospace; }
.table-wrap { overflow-x: auto; }
table { border-collapse: collapse; font-variant-numeric: tabular-nums; font-size: 0.9rem; }
th, td { padding: 5px 10px; border-bottom: 1px solid var(--line); text-align: left; white-space: nowrap; }
thead th { background: var(--panel); font-weight: 600; white-space: normal; vertical-align: bottom; }
td:not(.num):not(:first-child) { white-space: normal; min-width: 10em; }
.num { text-align: right; }
td.best { font-weight: 700; color: var(--accent); }
td.missing { color: var(--muted); }
.notes p { max-width: 75em; margin: 0 0 10px; }
.row { display: grid; grid-template-columns: repeat(auto-fill, minmax(260px, 1fr)); gap: 12px; }
figure { margin: 0; background: var(--panel); border: 1px solid var(--line); border-radius: 6px; overflow: hidden; }
figure.truth { border-color: var(--accent); }
figure img { display: block; width: 100%; height: auto; }
.pixelated figure img { image-rendering: pixelated; }
.no-image { display: grid; place-items: center; aspect-ratio: 4 / 3; color: var(--muted); }
figcaption { padding: 6px 10px 8px; }
figcaption .caption { font-weight: 600; }
figcaption .numbers { display: flex; flex-wrap: wrap; gap: 2px 14px; color: var(--muted); font-size: 0.9rem;
                      font-variant-numeric: tabular-nums; }
footer { margin-top: 40px; color: var(--muted); font-size: 0.85rem; }
)css";

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", &tm);
  return buf;
}

// Whether row `row` holds the best number of column `col` (every row that ties for best is marked).
bool is_best(const std::vector<Row>& rows, size_t col, Better better, size_t row) {
  if (better == Better::none || rows[row][col].kind != Cell::Kind::number) return false;
  double best = 0;
  bool any = false;
  for (const auto& r : rows) {
    if (r[col].kind != Cell::Kind::number) continue;
    double v = r[col].number;
    if (!any || (better == Better::higher ? v > best : v < best)) best = v;
    any = true;
  }
  return rows[row][col].number == best;
}

// A column's label as a header cell (column_label: "PSNR dB", not psnr), with an arrow that says which
// way is better where one is.
std::string header_cell(const std::string& name, Better better) {
  std::string text = html_escape(column_label(name));
  if (better == Better::lower) text += " <span title=\"lower is better\">&darr;</span>";
  if (better == Better::higher) text += " <span title=\"higher is better\">&uarr;</span>";
  return text;
}

void html_table(std::string& html, const ReportTable& table) {
  const auto& header = table.header;
  table_csv(header, table.rows, "HTML report table '" + table.title + "'");  // validates the widths with a clear error
  const std::vector<Row> rows = align_decimals(with_column_decimals(header, table.rows));
  std::vector<bool> numeric(header.size(), true);
  for (const auto& r : rows) {
    for (size_t j = 0; j < r.size(); ++j) numeric[j] = numeric[j] && r[j].kind != Cell::Kind::text;
  }
  html += "<h2>" + html_escape(table.title) + "</h2>\n<div class=\"table-wrap\"><table>\n<thead><tr>";
  for (size_t j = 0; j < header.size(); ++j) {
    const Better better = j < table.better.size() ? table.better[j] : Better::none;
    html += std::string(numeric[j] ? "<th class=\"num\">" : "<th>") + header_cell(header[j], better) + "</th>";
  }
  html += "</tr></thead>\n<tbody>\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    html += "<tr>";
    for (size_t j = 0; j < header.size(); ++j) {
      std::string cls = numeric[j] ? "num" : "";
      Better better = j < table.better.size() ? table.better[j] : Better::none;
      if (is_best(rows, j, better, i)) cls += " best";
      if (rows[i][j].missing()) cls += " missing";
      html += (cls.empty() ? "<td>" : "<td class=\"" + cls + "\">") + html_escape(display_text(rows[i][j])) + "</td>";
    }
    html += "</tr>\n";
  }
  html += "</tbody></table></div>\n";
}

cv::Mat shrink_to(const cv::Mat& image, int max_side) {
  int side = std::max(image.cols, image.rows);
  if (max_side <= 0 || side <= max_side) return image;
  double f = static_cast<double>(max_side) / side;
  return resize_area(image, std::max(1, static_cast<int>(std::lround(image.cols * f))),
                     std::max(1, static_cast<int>(std::lround(image.rows * f))));
}

void figure(std::string& html, const ReportImage& img, const std::string& view, bool truth, int max_side) {
  html += truth ? "<figure class=\"truth\">" : "<figure>";
  if (img.image.empty()) {
    html += "<div class=\"no-image\">no image</div>";
  } else {
    cv::Mat shown = shrink_to(img.image, max_side);
    html += "<img src=\"" + png_data_uri(shown) + "\" width=\"" + std::to_string(shown.cols) + "\" height=\"" +
            std::to_string(shown.rows) + "\" alt=\"" + html_escape(img.caption + ", " + view) + "\">";
  }
  html += "<figcaption><div class=\"caption\">" + html_escape(img.caption) + "</div>";
  if (!img.numbers.empty()) {
    html += "<div class=\"numbers\">";
    for (const auto& [name, value] : img.numbers) {
      html += "<span>" + html_escape(name) + " " + html_escape(display_text(value)) + "</span>";
    }
    html += "</div>";
  }
  html += "</figcaption></figure>\n";
}

}  // namespace

std::string html_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
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

std::string base64_encode(const std::string& bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8) | uint8_t(bytes[i + 2]);
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += table[v & 63];
  }
  if (i < bytes.size()) {  // 1 or 2 bytes left: pad to a full quantum
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string png_data_uri(const cv::Mat& image) {
  if (image.empty()) fail("report: empty image");
  if (image.channels() != 1 && image.channels() != 3) {
    fail("report: images must have 1 or 3 channels, got " + std::to_string(image.channels()));
  }
  if (image.depth() != CV_8U && image.depth() != CV_32F) fail("report: images must be 8-bit or float32");
  cv::Mat u8 = to_u8(image);  // rounds and clamps to [0, 255]
  cv::Mat bgr = u8;
  if (u8.channels() == 3) cv::cvtColor(u8, bgr, cv::COLOR_RGB2BGR);
  std::vector<uchar> png;
  if (!cv::imencode(".png", bgr, png)) fail("report: cannot encode an image as PNG");
  return "data:image/png;base64," + base64_encode(std::string(png.begin(), png.end()));
}

std::string html_report(const ReportSpec& spec) {
  std::string html;
  html += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  html += "<title>" + html_escape(spec.title) + "</title>\n<style>" + kCss + "</style>\n</head>\n<body>\n<main>\n";
  html += "<h1>" + html_escape(spec.title) + "</h1>\n";
  if (!spec.summary_header.empty()) {
    html_table(html, {"Summary", spec.summary_header, spec.summary_rows, spec.summary_better});
  }
  for (const auto& table : spec.tables) html_table(html, table);
  for (const auto& chart : spec.charts) html += "<div class=\"chart\">" + svg_chart(chart) + "</div>\n";
  if (!spec.notes.empty()) {
    html += "<h2>Notes</h2>\n<div class=\"notes\">\n";
    for (const auto& note : spec.notes) html += "<p>" + html_escape(note) + "</p>\n";
    html += "</div>\n";
  }
  if (!spec.views.empty()) {
    html += spec.pixelated ? "<section class=\"views pixelated\">\n" : "<section class=\"views\">\n";
    html += "<h2>Test views</h2>\n";
    for (const auto& view : spec.views) {
      html += "<h3>" + html_escape(view.name) + "</h3>\n<div class=\"row\">\n";
      figure(html, view.ground_truth, view.name, true, spec.max_image_side);
      for (const auto& m : view.methods) figure(html, m, view.name, false, spec.max_image_side);
      html += "</div>\n";
    }
    html += "</section>\n";
  }
  // version_string() starts with "lrf" itself.
  std::string footer = spec.footer.empty() ? "Written by " + version_string() + " on " + utc_now() : spec.footer;
  html += "<footer>" + html_escape(footer) + "</footer>\n</main>\n</body>\n</html>\n";
  return html;
}

void write_html_report(const std::string& path, const ReportSpec& spec) {
  std::string html;
  try {
    html = html_report(spec);
  } catch (const Error& e) {
    fail(path, e.what());
  }
  write_file_atomic(path, html);
}

}  // namespace lrf
