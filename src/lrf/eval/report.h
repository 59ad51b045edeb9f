#pragma once
// The HTML report of `lrf compare` / `lrf pipeline`: a title, a summary table, notes, and for each test
// view a row of images (ground truth, then each method) with captions and numbers. One self-contained
// file: images are embedded as base64 PNG data URIs and the CSS is inline, so the page opens from disk
// (or as an e-mail attachment) with no server, no JavaScript and no files beside it.
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/eval/chart.h"
#include "lrf/eval/table.h"

namespace lrf {

struct ReportImage {
  std::string caption;  // e.g. "ground truth", "latent"
  cv::Mat image;        // RGB float in [0, 1] or 8-bit, or one channel; empty = "no image" placeholder
  std::vector<std::pair<std::string, Cell>> numbers;  // e.g. {"PSNR", 25.43}, {"LPIPS", Cell()}
};

struct ReportView {
  std::string name;  // e.g. the test image's file name
  ReportImage ground_truth;
  std::vector<ReportImage> methods;
};

// Which way is better for a summary column: the best value of such a column is shown in bold.
enum class Better { none, higher, lower };

// A further table of the report, shown under its own heading after the summary.
struct ReportTable {
  std::string title;
  std::vector<std::string> header;
  std::vector<Row> rows;
  std::vector<Better> better;  // per column; may be empty
};

struct ReportSpec {
  std::string title;
  std::vector<std::string> summary_header;
  std::vector<Row> summary_rows;
  std::vector<Better> summary_better;  // per column; may be empty (no highlighting)
  std::vector<ReportTable> tables;     // after the summary (e.g. compare's efficiency table)
  std::vector<Chart> charts;           // after the tables (e.g. quality against wall time)
  std::vector<std::string> notes;      // paragraphs of plain text
  std::vector<ReportView> views;
  // Show pixels as squares when the browser enlarges small images (latent-resolution renders), so that
  // what is compared is the pixels, not the browser's interpolation.
  bool pixelated = false;
  // Images larger than this (width or height, in pixels) are shrunk for the page with an area filter,
  // to keep the file small; 0 = embed as given. Metrics are computed before, on the full images.
  int max_image_side = 0;
  std::string footer;  // empty: "Written by lrf <version> on <time of writing>"
};

// The page as a string; throws lrf::Error if the summary's rows do not match its header or an image
// cannot be encoded.
std::string html_report(const ReportSpec& spec);
void write_html_report(const std::string& path, const ReportSpec& spec);

// Escapes & < > " ' for HTML text and attribute values.
std::string html_escape(const std::string& text);
// Standard base64 (RFC 4648, with padding).
std::string base64_encode(const std::string& bytes);
// "data:image/png;base64,..." of an RGB (float [0, 1] or 8-bit) or one-channel image.
std::string png_data_uri(const cv::Mat& image);

}  // namespace lrf
