// `ftid analyze` on a log whose sensor streams slower than the log (held readings,
// include/ftid/samples/held_readings.hpp): the analysis is exactly that of the log without the
// held rows, plus one warning naming them. Kept, the repeated rows made the noise look coloured
// (lag-1 correlation 0.99), 745 "glitches" at the renewals, a floor of 0.23 N for the sensor's
// 0.05 N, and --explain stopped at `paper` with rigid_body's inertia in the data.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "ftid/lab/analyze.hpp"
#include "ftid/logio/log.hpp"
#include "lab_sim.hpp"
#include "test_paths.hpp"

namespace ftid::lab {
namespace {

AnalysisResult analyzeFile(const logio::LogData& log, const std::string& name) {
  const std::string path = ::testing::TempDir() + name;
  logio::writeLog(path, log);
  AnalyzeFilesRequest req;
  req.log_path = path;
  req.robot_urdf = test::sourcePath("/config/ur10.urdf");
  req.options.explain = true;
  AnalysisResult r = analyzeRecordings(req);
  std::remove(path.c_str());
  return r;
}

TEST(HeldReadingsLab, TheAnalysisIsThatOfTheRowsEachReadingArrivedWith) {
  sim::CellSimConfig cfg = labtest::baseConfig(21);
  cfg.full_rigid_body = true;
  cfg.rate_hz = 500.0;
  logio::LogData held = sim::CellSim(cfg).run();
  for (std::size_t i = 0; i < held.samples.size(); ++i) held.samples[i].wrench_S = held.samples[i - i % 4].wrench_S;
  logio::LogData fresh = held;
  fresh.samples.clear();
  for (std::size_t i = 0; i < held.samples.size(); i += 4) fresh.samples.push_back(held.samples[i]);

  // One file name for both: the suggested commands name the log.
  AnalysisResult a = analyzeFile(held, "held_readings_lab.csv");
  AnalysisResult b = analyzeFile(fresh, "held_readings_lab.csv");
  ASSERT_FALSE(a.warnings.empty());
  EXPECT_NE(a.warnings.front().find("3750 rows repeat the previous row's wrench bit for bit"), std::string::npos)
      << a.warnings.front();
  EXPECT_EQ(a.final_report ? a.final_report->model : a.report.model, "paper+rigid_body");
  a.warnings.erase(a.warnings.begin());
  a.seconds = b.seconds = 0.0;
  EXPECT_TRUE(formatJson(a) == formatJson(b));  // (not EXPECT_EQ: the JSON is ~100 kB)
}

}  // namespace
}  // namespace ftid::lab
