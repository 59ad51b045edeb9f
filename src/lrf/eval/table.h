#pragma once
// Result tables (`lrf compare`'s table.csv / table.md, the HTML report's summary): cells that are numbers,
// text, or missing (a metric that could not be computed, e.g. LPIPS without weights).
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

namespace lrf {

struct Cell {
  enum class Kind { empty, number, text };
  Kind kind = Kind::empty;
  double number = 0.0;
  // Decimals shown in markdown and HTML; -1 = automatic (integers without decimals, else 4 significant
  // digits: 25.43, 0.8123, 123.4). CSV always writes 6 significant digits (%g), for machines.
  int decimals = -1;
  std::string text;

  Cell() = default;
  Cell(std::nullopt_t) {}
  // NaN counts as missing.
  Cell(double v, int display_decimals = -1);
  template <typename T, typename = std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>>>
  Cell(T v) : Cell(static_cast<double>(v), 0) {}
  Cell(std::optional<double> v, int display_decimals = -1) : Cell(v ? Cell(*v, display_decimals) : Cell()) {}
  Cell(const char* s) : kind(Kind::text), text(s) {}
  Cell(std::string s) : kind(Kind::text), text(std::move(s)) {}
  // null → missing, number → number, string → text; anything else is shown as its JSON text.
  static Cell from_json(const nlohmann::json& value, int display_decimals = -1);
  // object[key] when the object has it as a number, else missing (for optional metrics).
  static Cell number_in(const nlohmann::json& object, const char* key);

  bool missing() const { return kind == Kind::empty; }
};

using Row = std::vector<Cell>;

// A number for display: `decimals` >= 0 fixes them; -1 is automatic: auto_decimals(value, significant),
// or %g where that is -1.
std::string format_number(double value, int decimals = -1, int significant = 4);
// Decimals that show `value` with `significant` digits (0 for integers): 25.43, 0.8123, 0.01235, 1235.
// -1 where fixed decimals do not suit (magnitude below 1e-3, or not finite).
int auto_decimals(double value, int significant = 4);
// `rows` with each automatic number cell given its column's largest auto_decimals, so that a column's
// numbers line up ("100.0" above "137.2"); cells with fixed decimals keep theirs.
std::vector<Row> align_decimals(const std::vector<Row>& rows);
// The cell as shown in markdown/HTML; `missing` for an empty cell.
std::string display_text(const Cell& cell, const std::string& missing = "\u2013");

// How a person reads a column of lrf's tables: its label with its unit ("PSNR dB" for psnr, "Δ PSNR dB"
// for delta_psnr, "fit time s" for train_seconds; a key it does not know with spaces for underscores) and
// the decimals its numbers are shown with (2 for PSNRs, 3 for SSIM, FLIP and LPIPS; -1: automatic).
// CSV files keep the keys and full precision, for machines.
std::string column_label(const std::string& key);
int column_decimals(const std::string& key);
// `rows` with each automatic number cell of a known column given that column's decimals.
std::vector<Row> with_column_decimals(const std::vector<std::string>& header, const std::vector<Row>& rows);

// RFC 4180 CSV: a header line, then one line per row; fields with commas, quotes or newlines are quoted.
// Missing cells are empty. Throws lrf::Error naming `path` if a row's width differs from the header's.
std::string table_csv(const std::vector<std::string>& header, const std::vector<Row>& rows,
                      const std::string& path = "");
void write_table_csv(const std::string& path, const std::vector<std::string>& header, const std::vector<Row>& rows);

// A GitHub-flavoured markdown table with padded columns, headed by column_label and numbers shown with
// column_decimals; numeric columns are right-aligned with aligned decimals (align_decimals), missing cells
// show "–", and `|` in text is escaped.
std::string table_markdown(const std::vector<std::string>& header, const std::vector<Row>& rows,
                           const std::string& path = "");
void write_table_markdown(const std::string& path, const std::vector<std::string>& header,
                          const std::vector<Row>& rows);

}  // namespace lrf
