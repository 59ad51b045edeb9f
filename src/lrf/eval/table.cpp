#include "lrf/eval/table.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

std::string printf_double(const char* format, int precision, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, precision, v);
  return buf;
}

void check_widths(const std::vector<std::string>& header, const std::vector<Row>& rows, const std::string& path) {
  if (header.empty()) fail(path, "table has no columns");
  for (size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].size() != header.size()) {
      fail(path, "table row " + std::to_string(i + 1) + " has " + std::to_string(rows[i].size()) +
                     " cells, the header has " + std::to_string(header.size()));
    }
  }
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string csv_cell(const Cell& c) {
  switch (c.kind) {
    case Cell::Kind::empty: return "";
    case Cell::Kind::number: {
      // Six significant digits without trailing zeros (%g): enough for any metric, short for machines.
      double v = c.number;
      if (std::isfinite(v) && std::fabs(v) < 1e15 && v == std::round(v)) return printf_double("%.*f", 0, v);
      return printf_double("%.*g", 6, v);
    }
    case Cell::Kind::text: return csv_field(c.text);
  }
  return "";
}

// Pipes would end the markdown cell and newlines the row.
std::string markdown_text(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '|') {
      out += "\\|";
    } else if (c == '\n' || c == '\r') {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

// Display width in characters of UTF-8 text (so that "–" pads like one character).
size_t utf8_width(const std::string& s) {
  size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

std::string pad(const std::string& s, size_t width, bool right) {
  std::string fill(width > utf8_width(s) ? width - utf8_width(s) : 0, ' ');
  return right ? fill + s : s + fill;
}

}  // namespace

Cell::Cell(double v, int display_decimals) {
  if (std::isnan(v)) return;
  kind = Kind::number;
  number = v;
  decimals = display_decimals;
}

Cell Cell::from_json(const nlohmann::json& value, int display_decimals) {
  if (value.is_null()) return Cell();
  if (value.is_number_integer()) return Cell(value.get<double>(), display_decimals < 0 ? 0 : display_decimals);
  if (value.is_number()) return Cell(value.get<double>(), display_decimals);
  if (value.is_string()) return Cell(value.get<std::string>());
  return Cell(value.dump());
}

Cell Cell::number_in(const nlohmann::json& object, const char* key) {
  return object.is_object() && object.contains(key) && object[key].is_number() ? Cell(object[key].get<double>()) : Cell();
}

int auto_decimals(double v, int significant) {
  if (!std::isfinite(v)) return -1;
  double a = std::fabs(v);
  if (a < 1e15 && v == std::round(v)) return 0;
  if (a >= 1.0) return std::max(0, significant - (static_cast<int>(std::floor(std::log10(a))) + 1));
  if (a >= 1e-3) return significant - 1 - static_cast<int>(std::floor(std::log10(a)));
  return -1;
}

std::string format_number(double v, int decimals, int significant) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (decimals < 0) decimals = auto_decimals(v, significant);
  if (decimals < 0) return printf_double("%.*g", significant, v);  // 1.2e-05
  return printf_double("%.*f", decimals, v);
}

std::vector<Row> align_decimals(const std::vector<Row>& rows) {
  size_t columns = 0;
  for (const auto& r : rows) columns = std::max(columns, r.size());
  std::vector<int> decimals(columns, 0);
  std::vector<bool> alignable(columns, true);  // false if a cell needs %g
  for (const auto& r : rows) {
    for (size_t j = 0; j < r.size(); ++j) {
      if (r[j].kind != Cell::Kind::number || r[j].decimals >= 0) continue;
      int d = auto_decimals(r[j].number);
      if (d < 0) alignable[j] = false;
      decimals[j] = std::max(decimals[j], d);
    }
  }
  std::vector<Row> out = rows;
  for (auto& r : out) {
    for (size_t j = 0; j < r.size(); ++j) {
      if (r[j].kind == Cell::Kind::number && r[j].decimals < 0 && alignable[j]) r[j].decimals = decimals[j];
    }
  }
  return out;
}

std::string display_text(const Cell& cell, const std::string& missing) {
  switch (cell.kind) {
    case Cell::Kind::empty: return missing;
    case Cell::Kind::number: return format_number(cell.number, cell.decimals);
    case Cell::Kind::text: return cell.text;
  }
  return missing;
}

std::string table_csv(const std::vector<std::string>& header, const std::vector<Row>& rows, const std::string& path) {
  check_widths(header, rows, path);
  std::string out;
  for (size_t j = 0; j < header.size(); ++j) out += (j ? "," : "") + csv_field(header[j]);
  out += "\n";
  for (const auto& row : rows) {
    for (size_t j = 0; j < row.size(); ++j) out += (j ? "," : "") + csv_cell(row[j]);
    out += "\n";
  }
  return out;
}

void write_table_csv(const std::string& path, const std::vector<std::string>& header, const std::vector<Row>& rows) {
  write_file_atomic(path, table_csv(header, rows, path));
}

namespace {

struct ColumnStyle {
  const char* key;
  const char* label;
  int decimals;
};

// The columns compare, pipeline and eval share. PSNR to 0.01 dB and SSIM-like scores to 0.001 are the
// precision the paper reports and more than runs repeat to.
const ColumnStyle kColumns[] = {
    {"psnr", "PSNR dB", 2},          {"delta_psnr", "\u0394 PSNR dB", 2}, {"latent_psnr", "latent PSNR dB", 2},
    {"roundtrip_psnr", "round trip PSNR dB", 2}, {"ssim", "SSIM", 3}, {"ms_ssim", "MS-SSIM", 3},
    {"flip", "FLIP", 3},             {"lpips", "LPIPS", 3},          {"train_seconds", "fit time s", 0},
    {"peak_memory_mb", "peak memory MB", 0}, {"storage_mb", "storage MB", 1}, {"gaussians", "Gaussians", 0},
    {"render_fps", "render fps", 1}, {"decode_fps", "decode fps", 1}, {"view_fps", "view fps", 1},
    {"fitted_to", "fitted to", -1},  {"seconds", "seconds", 0},      {"wall_seconds", "wall time s", 0}};

const ColumnStyle* column_style(const std::string& key) {
  for (const ColumnStyle& c : kColumns)
    if (key == c.key) return &c;
  return nullptr;
}

}  // namespace

std::string column_label(const std::string& key) {
  if (const ColumnStyle* c = column_style(key)) return c->label;
  std::string label = key;
  std::replace(label.begin(), label.end(), '_', ' ');
  return label;
}

int column_decimals(const std::string& key) {
  const ColumnStyle* c = column_style(key);
  return c ? c->decimals : -1;
}

std::vector<Row> with_column_decimals(const std::vector<std::string>& header, const std::vector<Row>& rows) {
  std::vector<Row> out = rows;
  for (Row& row : out) {
    for (size_t j = 0; j < row.size() && j < header.size(); ++j) {
      const int decimals = column_decimals(header[j]);
      if (decimals >= 0 && row[j].kind == Cell::Kind::number && row[j].decimals < 0) row[j].decimals = decimals;
    }
  }
  return out;
}

std::string table_markdown(const std::vector<std::string>& header, const std::vector<Row>& given_rows,
                           const std::string& path) {
  check_widths(header, given_rows, path);
  const std::vector<Row> rows = align_decimals(with_column_decimals(header, given_rows));
  const size_t n = header.size();
  std::vector<std::vector<std::string>> text(rows.size(), std::vector<std::string>(n));
  std::vector<size_t> width(n, 3);  // "---" at least
  std::vector<bool> numeric(n, true);
  for (size_t j = 0; j < n; ++j) width[j] = std::max(width[j], utf8_width(markdown_text(column_label(header[j]))));
  for (size_t i = 0; i < rows.size(); ++i) {
    for (size_t j = 0; j < n; ++j) {
      text[i][j] = markdown_text(display_text(rows[i][j]));
      width[j] = std::max(width[j], utf8_width(text[i][j]));
      if (rows[i][j].kind == Cell::Kind::text) numeric[j] = false;
    }
  }
  auto line = [&](const std::vector<std::string>& cells) {
    std::string out = "|";
    for (size_t j = 0; j < n; ++j) out += " " + pad(cells[j], width[j], numeric[j]) + " |";
    return out + "\n";
  };
  std::vector<std::string> head(n);
  for (size_t j = 0; j < n; ++j) head[j] = markdown_text(column_label(header[j]));
  std::string out = line(head) + "|";
  for (size_t j = 0; j < n; ++j) {
    out += " " + (numeric[j] ? std::string(width[j] - 1, '-') + ":" : std::string(width[j], '-')) + " |";
  }
  out += "\n";
  for (const auto& row : text) out += line(row);
  return out;
}

void write_table_markdown(const std::string& path, const std::vector<std::string>& header,
                          const std::vector<Row>& rows) {
  write_file_atomic(path, table_markdown(header, rows, path));
}

}  // namespace lrf
