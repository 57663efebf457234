// The HTML report: self-contained (no network references), and it renders to a non-blank page in
// headless Chromium (skipped with the reason when Debian's chromium is not installed).
#include <gtest/gtest.h>

#include <cmath>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>
#ifdef FTID_HAVE_ZLIB
#include <zlib.h>
#endif

#include "ftid/lab/analyze.hpp"
#include "lab_sim.hpp"

namespace {

using namespace ftid;

std::string readFile(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string findChromium() {
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (::access(c, X_OK) == 0) return c;
  }
  return "";
}

/// A fresh scratch directory under the test temp dir, removed with everything in it (Chromium's
/// profile too) when the test ends, however it ends.
class ScratchDir {
 public:
  ScratchDir() {
    std::string tmpl = ::testing::TempDir() + "ftid_report_XXXXXX";
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + tmpl);
    path_ = tmpl;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

std::uint32_t be32(const std::string& s, std::size_t at) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 3]));
}

class Report : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto cfg = labtest::baseConfig(91);
    cfg.full_rigid_body = true;
    result_ = new lab::AnalysisResult(labtest::analyzeRun(cfg, "paper", true));
    html_ = new std::string(lab::renderHtml(*result_));
  }
  static void TearDownTestSuite() {
    delete result_;
    delete html_;
  }
  static lab::AnalysisResult* result_;
  static std::string* html_;
};
lab::AnalysisResult* Report::result_ = nullptr;
std::string* Report::html_ = nullptr;

TEST_F(Report, IsSelfContained) {
  const std::string& h = *html_;
  EXPECT_EQ(h.find("http://"), std::string::npos);
  EXPECT_EQ(h.find("https://"), std::string::npos);
  EXPECT_EQ(h.find("<script"), std::string::npos);
  EXPECT_EQ(h.find("<link"), std::string::npos);
  EXPECT_EQ(h.find("src="), std::string::npos);
  EXPECT_NE(h.find("<svg"), std::string::npos);
  // The four kinds of plot: measured vs model, residual with windows, residual vs signal, explain bars.
  EXPECT_NE(h.find("Measured vs model"), std::string::npos);
  EXPECT_NE(h.find("worst windows shaded"), std::string::npos);
  EXPECT_NE(h.find("most related signal"), std::string::npos);
  EXPECT_NE(h.find("error falling step by step"), std::string::npos);
  EXPECT_NE(h.find("rigid_body"), std::string::npos);
  // Provenance (version, date, log, models) and the k-fold block boundaries: folds - 1 lines in
  // each of the 12 time plots.
  EXPECT_NE(h.find("Provenance: ftid "), std::string::npos);
  EXPECT_NE(h.find(" UTC; log <code>"), std::string::npos);
  std::size_t fold_lines = 0;
  for (std::size_t at = h.find("class=\"fold\""); at != std::string::npos; at = h.find("class=\"fold\"", at + 1)) ++fold_lines;
  EXPECT_EQ(fold_lines, 12u * static_cast<std::size_t>(result_->folds - 1));
}

// Before / after (issue 12 item 7): the starting and the final model's held-out residual on the
// same samples, overlaid per axis, with a table of both RMS values. The plotted final series must be
// the residual the final model's RMS was computed from, and the error must fall.
TEST_F(Report, OverlaysTheStartingAndTheFinalModelsResidual) {
  const lab::AnalysisResult& r = *result_;
  ASSERT_TRUE(r.final_report.has_value());
  ASSERT_NE(r.final_report->model, r.report.model);
  ASSERT_EQ(r.final_residual.cols(), static_cast<Eigen::Index>(r.t.size()));
  ASSERT_EQ(r.outliers.count, 0) << "glitches are left out of the RMS but plotted; this run has none";
  for (int a = 0; a < 6; ++a) {
    const double rms = std::sqrt(r.final_residual.row(a).squaredNorm() / static_cast<double>(r.t.size()));
    EXPECT_NEAR(rms, r.final_report->residual_rms(a), 1e-9 * (1.0 + rms)) << "axis " << a;
    const double start = std::sqrt((r.measured.row(a) - r.predicted.row(a)).squaredNorm() / static_cast<double>(r.t.size()));
    EXPECT_NEAR(start, r.report.residual_rms(a), 1e-9 * (1.0 + start)) << "axis " << a;
  }
  // The data carry the full rigid body, the start is the paper model: the final model does better.
  EXPECT_LT(r.final_report->residual_rms.norm(), 0.9 * r.report.residual_rms.norm());

  const std::string& h = *html_;
  const std::size_t at = h.find("<h2>Before and after: held-out residual of the starting model <code>paper</code>");
  ASSERT_NE(at, std::string::npos);
  const std::size_t end = h.find("<h2>", at + 4);
  const std::string section = h.substr(at, end - at);
  EXPECT_NE(section.find("<code>" + r.final_report->model + "</code>"), std::string::npos);
  EXPECT_NE(section.find("class=\"before-after\""), std::string::npos);
  std::size_t svgs = 0, lines = 0;
  for (std::size_t p = section.find("<svg"); p != std::string::npos; p = section.find("<svg", p + 1)) ++svgs;
  for (std::size_t p = section.find("<polyline"); p != std::string::npos; p = section.find("<polyline", p + 1)) ++lines;
  EXPECT_EQ(svgs, 6u);
  EXPECT_EQ(lines, 12u);  // start and final in each
  for (const char* axis : {"fx", "fy", "fz", "tx", "ty", "tz"}) {
    EXPECT_NE(section.find(std::string("residual ") + axis + ": start RMS "), std::string::npos) << axis;
  }
  // Without explain there is no final model and no overlay.
  lab::AnalysisResult no_final = r;
  no_final.final_report.reset();
  no_final.final_residual.resize(6, 0);
  EXPECT_EQ(lab::renderHtml(no_final).find("Before and after"), std::string::npos);
}

// With --explain the report ends the path with every remaining candidate's verdict in words.
TEST_F(Report, SaysWhyEachRemainingCandidateWasNotTaken) {
  const lab::AnalysisResult& r = *result_;
  const std::string& h = *html_;
  const std::size_t at = h.find("why each remaining candidate was not taken");
  ASSERT_NE(at, std::string::npos);
  const std::string section = h.substr(at, h.find("</table>", at) - at);
  ASSERT_FALSE(r.final_candidates.empty());
  for (const auto& c : r.final_candidates) {
    EXPECT_NE(section.find("<tr><td>" + c.effect + "</td><td>" + lab::verdictWord(c.verdict) + "</td>"),
              std::string::npos) << c.effect;
    if (!c.skipped) {
      EXPECT_FALSE(c.reason.empty()) << c.effect;
    }
  }
}

TEST_F(Report, RendersInHeadlessChromium) {
  const std::string chromium = findChromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (apt-get install -y chromium)";
  const ScratchDir scratch;
  const std::string dir = scratch.path();
  const std::string html_path = dir + "/report.html";
  const std::string png_path = dir + "/out.png";
  lab::writeTextFileAtomically(html_path, *html_);
  const std::string cmd = chromium +
                          " --headless --no-sandbox --disable-gpu --disable-background-networking"
                          " --disable-component-update --disable-sync --no-first-run --user-data-dir=" +
                          dir + "/profile --screenshot=" + png_path + " --window-size=1200,2000 file://" + html_path +
                          " > " + dir + "/chromium.log 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_EQ(rc, 0) << readFile(dir + "/chromium.log");
  const std::string png = readFile(png_path);
  ASSERT_GT(png.size(), 1000u) << "no screenshot written";
  ASSERT_EQ(png.substr(1, 3), "PNG");
  EXPECT_EQ(be32(png, 16), 1200u);  // IHDR width
  EXPECT_EQ(be32(png, 20), 2000u);  // IHDR height
#ifdef FTID_HAVE_ZLIB
  // Inflate the image data and count distinct byte values of the scanlines: a blank page has one
  // colour (plus the filter bytes); plots give many.
  std::string idat;
  for (std::size_t at = 8; at + 8 <= png.size();) {
    const std::uint32_t len = be32(png, at);
    const std::string type = png.substr(at + 4, 4);
    if (type == "IDAT") idat += png.substr(at + 8, len);
    at += 12 + len;
  }
  const int bit_depth = static_cast<unsigned char>(png[24]);
  const int colour = static_cast<unsigned char>(png[25]);
  ASSERT_EQ(bit_depth, 8);
  const int channels = colour == 6 ? 4 : colour == 2 ? 3 : colour == 0 ? 1 : 0;
  ASSERT_GT(channels, 0);
  const std::size_t stride = 1 + 1200u * static_cast<std::size_t>(channels);
  std::vector<unsigned char> raw(stride * 2000u);
  uLongf raw_len = raw.size();
  ASSERT_EQ(uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()), idat.size()), Z_OK);
  // Undo the PNG filters (None/Sub/Up/Average/Paeth) and count non-white pixels.
  std::vector<unsigned char> prev(stride - 1, 0), cur(stride - 1);
  const int bpp = channels;
  std::size_t non_white = 0;
  for (std::size_t y = 0; y < 2000; ++y) {
    const unsigned char* line = raw.data() + y * stride;
    const int filter = line[0];
    for (std::size_t x = 0; x < stride - 1; ++x) {
      const int a = x >= static_cast<std::size_t>(bpp) ? cur[x - static_cast<std::size_t>(bpp)] : 0;
      const int b = prev[x];
      const int c = x >= static_cast<std::size_t>(bpp) ? prev[x - static_cast<std::size_t>(bpp)] : 0;
      int v = line[1 + x];
      switch (filter) {
        case 1: v += a; break;
        case 2: v += b; break;
        case 3: v += (a + b) / 2; break;
        case 4: {
          const int p = a + b - c;
          const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
          v += (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
          break;
        }
        default: break;
      }
      cur[x] = static_cast<unsigned char>(v & 0xff);
    }
    for (std::size_t x = 0; x + static_cast<std::size_t>(channels) <= cur.size(); x += static_cast<std::size_t>(channels)) {
      if (cur[x] < 200 || cur[x + (channels > 1 ? 1 : 0)] < 200) ++non_white;
    }
    prev = cur;
  }
  EXPECT_GT(non_white, 20000u) << "the screenshot is (nearly) blank";
#endif
}

}  // namespace
