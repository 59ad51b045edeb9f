#include <filesystem>
#include <regex>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/eval/report.h"
#include "lrf/eval/table.h"
#include "test_helpers.h"

namespace {

// Independent of the writer's encoder: decodes standard base64 with padding.
std::string base64_decode(const std::string& s) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
  };
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    int v = value(c);
    if (v < 0) ADD_FAILURE() << "bad base64 character " << c;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xFF);
    }
  }
  return out;
}

// Checks that every element is closed in order (void elements excepted): the page is well-formed.
void expect_balanced_tags(const std::string& html) {
  static const std::regex tag(R"(<(/?)([a-zA-Z][a-zA-Z0-9]*)[^>]*>)");
  static const std::vector<std::string> void_elements = {"meta", "img", "br", "hr", "link", "wbr"};
  std::vector<std::string> stack;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), tag); it != std::sregex_iterator(); ++it) {
    std::string name = (*it)[2];
    if (std::find(void_elements.begin(), void_elements.end(), name) != void_elements.end()) continue;
    if ((*it)[1] == "/") {
      ASSERT_FALSE(stack.empty()) << "unexpected </" << name << ">";
      ASSERT_EQ(stack.back(), name) << "mismatched </" << name << ">";
      stack.pop_back();
    } else {
      stack.push_back(name);
    }
  }
  EXPECT_TRUE(stack.empty()) << "unclosed <" << (stack.empty() ? "" : stack.back()) << ">";
}

size_t count(const std::string& haystack, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = haystack.find(needle); pos != std::string::npos; pos = haystack.find(needle, pos + 1)) ++n;
  return n;
}

cv::Mat gradient_image(int w, int h, float tint) {
  cv::Mat img(h, w, CV_32FC3);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) img.at<cv::Vec3f>(r, c) = {float(c) / w, float(r) / h, tint};
  }
  return img;
}

}  // namespace

TEST(EvalTable, FormatsNumbersSensibly) {
  EXPECT_EQ(lrf::format_number(25.43217), "25.43");
  EXPECT_EQ(lrf::format_number(0.812345), "0.8123");
  EXPECT_EQ(lrf::format_number(123.456), "123.5");
  EXPECT_EQ(lrf::format_number(1234.56), "1235");
  EXPECT_EQ(lrf::format_number(150000), "150000");
  EXPECT_EQ(lrf::format_number(0.0123456), "0.01235");
  EXPECT_EQ(lrf::format_number(0.75), "0.7500");
  EXPECT_EQ(lrf::format_number(1.2345e-5), "1.234e-05");
  EXPECT_EQ(lrf::format_number(-3.14159), "-3.142");
  EXPECT_EQ(lrf::format_number(25.43217, 1), "25.4");
  EXPECT_EQ(lrf::format_number(25.43217, -1, 6), "25.4322");
  EXPECT_EQ(lrf::display_text(lrf::Cell()), "\u2013");
  EXPECT_EQ(lrf::display_text(lrf::Cell(std::nan(""))), "\u2013");
  EXPECT_EQ(lrf::display_text(lrf::Cell::from_json(nullptr)), "\u2013");
  EXPECT_EQ(lrf::display_text(lrf::Cell::from_json(42)), "42");
  EXPECT_EQ(lrf::display_text(lrf::Cell::from_json("x")), "x");
}

TEST(EvalTable, ColumnsShareTheirDecimals) {
  auto rows = lrf::align_decimals({{100.0, 0.5, lrf::Cell(3.0, 1)}, {137.25, 0.0123, 2.5}, {lrf::Cell(), 1e-5, 7}});
  EXPECT_EQ(lrf::display_text(rows[0][0]), "100.0");   // 137.25 needs one decimal: the column gets one
  EXPECT_EQ(lrf::display_text(rows[1][0]), "137.2");   // (round-half-even of the binary value)
  EXPECT_EQ(lrf::display_text(rows[0][1]), "0.5000");  // 1e-5 needs %g: the column stays per cell
  EXPECT_EQ(lrf::display_text(rows[2][1]), "1e-05");
  EXPECT_EQ(lrf::display_text(rows[0][2]), "3.0");     // fixed decimals are kept,
  EXPECT_EQ(lrf::display_text(rows[1][2]), "2.500");   // the automatic cell gets 4 significant digits,
  EXPECT_EQ(lrf::display_text(rows[2][2]), "7");       // integers are counts: no decimals
}

TEST(EvalTable, CsvAndMarkdownFiles) {
  lrf::test::TempDir dir("eval_table");
  std::vector<std::string> header = {"method", "psnr", "ssim", "lpips", "gaussians"};
  std::vector<lrf::Row> rows = {
      {"rgb/8", 21.123456, 0.71234, lrf::Cell(), 12000},
      {"latent, \"stock\"", 22.5, 0.75, 0.3127, int64_t{34567}},
      {"a|b", lrf::Cell(19.0, 2), std::nullopt, std::optional<double>(0.25), 5},
  };
  lrf::write_table_csv(dir / "table.csv", header, rows);
  EXPECT_EQ(lrf::read_file(dir / "table.csv"),
            "method,psnr,ssim,lpips,gaussians\n"
            "rgb/8,21.1235,0.71234,,12000\n"
            "\"latent, \"\"stock\"\"\",22.5,0.75,0.3127,34567\n"
            "a|b,19,,0.25,5\n");
  lrf::write_table_markdown(dir / "table.md", header, rows);
  EXPECT_EQ(lrf::read_file(dir / "table.md"),
            "| method          | PSNR dB |  SSIM | LPIPS | Gaussians |\n"
            "| --------------- | ------: | ----: | ----: | --------: |\n"
            "| rgb/8           |   21.12 | 0.712 |     \u2013 |     12000 |\n"
            "| latent, \"stock\" |   22.50 | 0.750 | 0.313 |     34567 |\n"
            "| a\\|b            |   19.00 |     \u2013 | 0.250 |         5 |\n");
  // Keys it does not know are shown with spaces for underscores.
  EXPECT_EQ(lrf::column_label("delta_psnr"), "\u0394 PSNR dB");
  EXPECT_EQ(lrf::column_label("train_seconds"), "fit time s");
  EXPECT_EQ(lrf::column_label("some_new_column"), "some new column");
}

TEST(EvalTable, RowWidthMismatchNamesTheFile) {
  lrf::test::TempDir dir("eval_table_bad");
  try {
    lrf::write_table_csv(dir / "t.csv", {"a", "b"}, {{1, 2}, {3}});
    FAIL() << "expected an error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.csv"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("row 2 has 1 cells"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "t.csv"));
}

TEST(EvalReport, Base64MatchesRfc4648Vectors) {
  EXPECT_EQ(lrf::base64_encode(""), "");
  EXPECT_EQ(lrf::base64_encode("f"), "Zg==");
  EXPECT_EQ(lrf::base64_encode("fo"), "Zm8=");
  EXPECT_EQ(lrf::base64_encode("foo"), "Zm9v");
  EXPECT_EQ(lrf::base64_encode("foob"), "Zm9vYg==");
  EXPECT_EQ(lrf::base64_encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(lrf::base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(lrf::base64_encode(std::string("\xff\x00\xfe", 3)), "/wD+");
}

TEST(EvalReport, SelfContainedPageWithViewsAndNumbers) {
  lrf::test::TempDir dir("eval_report");
  lrf::ReportSpec spec;
  spec.title = "fern: rgb/8 vs latent <TAEF2> & friends";
  spec.summary_header = {"method", "psnr", "ssim", "lpips"};
  spec.summary_rows = {{"rgb/8", 19.87, 0.6012, lrf::Cell()},
                       {"rgb/8-mip", 20.11, 0.6101, lrf::Cell()},
                       {"latent", 21.43, 0.6561, lrf::Cell()}};
  spec.summary_better = {lrf::Better::none, lrf::Better::higher, lrf::Better::higher, lrf::Better::lower};
  spec.notes = {"LPIPS needs --lpips-weights; not given, so it is \"null\".", "Second note."};
  const std::vector<std::string> methods = {"rgb/8", "rgb/8-mip", "latent"};
  const int widths[2] = {96, 80}, heights[2] = {64, 60};
  for (int v = 0; v < 2; ++v) {
    lrf::ReportView view;
    view.name = "IMG_00" + std::to_string(v) + ".JPG";
    view.ground_truth = {"ground truth", gradient_image(widths[v], heights[v], 0.5f), {}};
    for (size_t m = 0; m < methods.size(); ++m) {
      double psnr = 18.0 + v + 0.5 * static_cast<double>(m) + 0.001;
      view.methods.push_back({methods[m], gradient_image(widths[v], heights[v], 0.2f * float(m)),
                              {{"PSNR", psnr}, {"SSIM", 0.5 + 0.1 * static_cast<double>(m)}, {"LPIPS", lrf::Cell()}}});
    }
    spec.views.push_back(view);
  }
  std::string path = dir / "report.html";
  lrf::write_html_report(path, spec);
  std::string html = lrf::read_file(path);

  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  expect_balanced_tags(html);
  EXPECT_EQ(html.find("<script"), std::string::npos);  // no JavaScript
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);  // nothing fetched from elsewhere
  // Text is escaped, in the title and the notes.
  EXPECT_NE(html.find("<h1>fern: rgb/8 vs latent &lt;TAEF2&gt; &amp; friends</h1>"), std::string::npos);
  EXPECT_NE(html.find("so it is &quot;null&quot;."), std::string::npos);
  EXPECT_EQ(html.find("<TAEF2>"), std::string::npos);
  // Summary: numbers, the missing LPIPS, and the best PSNR/SSIM in bold.
  EXPECT_NE(html.find("<td class=\"num best\">21.43</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num best\">0.656</td>"), std::string::npos);  // SSIM to 3 decimals
  EXPECT_NE(html.find("<td class=\"num\">19.87</td>"), std::string::npos);
  EXPECT_EQ(count(html, "<td class=\"num missing\">\u2013</td>"), 3u);
  // Per view: its name, ground truth first, then the methods with their numbers.
  for (int v = 0; v < 2; ++v) {
    std::string name = "<h3>IMG_00" + std::to_string(v) + ".JPG</h3>";
    size_t at = html.find(name);
    ASSERT_NE(at, std::string::npos) << name;
    size_t truth = html.find("<div class=\"caption\">ground truth</div>", at);
    size_t last = html.find("<div class=\"caption\">latent</div>", at);
    EXPECT_LT(truth, last);
    EXPECT_NE(html.find("<span>PSNR " + lrf::format_number(18.0 + v + 1.001) + "</span>", at), std::string::npos);
  }
  EXPECT_EQ(count(html, "<span>LPIPS \u2013</span>"), 6u);
  // 2 views × (ground truth + 3 methods) embedded PNGs that decode to the images' sizes.
  static const std::regex uri("src=\"data:image/png;base64,([A-Za-z0-9+/=]+)\"");
  std::vector<cv::Size> sizes;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), uri); it != std::sregex_iterator(); ++it) {
    std::string png = base64_decode((*it)[1]);
    cv::Mat img = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
    ASSERT_FALSE(img.empty());
    sizes.push_back(img.size());
  }
  ASSERT_EQ(sizes.size(), 8u);
  for (size_t i = 0; i < sizes.size(); ++i) EXPECT_EQ(sizes[i], cv::Size(widths[i / 4], heights[i / 4])) << i;
}

TEST(EvalReport, PngRoundTripKeepsPixelsAndColourOrder) {
  cv::Mat rgb(2, 3, CV_8UC3, cv::Scalar(200, 10, 30));  // RGB: red-ish
  std::string uri = lrf::png_data_uri(rgb);
  ASSERT_EQ(uri.rfind("data:image/png;base64,", 0), 0u);
  std::string png = base64_decode(uri.substr(std::string("data:image/png;base64,").size()));
  cv::Mat bgr = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(bgr.size(), cv::Size(3, 2));
  EXPECT_EQ(bgr.at<cv::Vec3b>(1, 2), cv::Vec3b(30, 10, 200));
  EXPECT_THROW(lrf::png_data_uri(cv::Mat(2, 2, CV_8UC4)), lrf::Error);
}

TEST(EvalReport, LargeImagesCanBeShrunkForThePage) {
  lrf::ReportSpec spec;
  spec.title = "t";
  spec.max_image_side = 50;
  spec.views = {{"v", {"ground truth", gradient_image(200, 100, 0.5f), {}}, {{"m", gradient_image(40, 30, 0.f), {}}}}};
  std::string html = lrf::html_report(spec);
  EXPECT_NE(html.find("width=\"50\" height=\"25\""), std::string::npos);  // 200×100 → 50×25
  EXPECT_NE(html.find("width=\"40\" height=\"30\""), std::string::npos);  // small enough: as given
}

TEST(EvalReport, BadSummaryNamesTheFileAndWritesNothing) {
  lrf::test::TempDir dir("eval_report_bad");
  lrf::ReportSpec spec;
  spec.title = "t";
  spec.summary_header = {"method", "psnr"};
  spec.summary_rows = {{"a"}};
  try {
    lrf::write_html_report(dir / "r.html", spec);
    FAIL() << "expected an error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("r.html"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "r.html"));
}
