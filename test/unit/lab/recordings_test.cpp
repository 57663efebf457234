// lab::checkEnoughSamples and lab::analyzeRecordings (include/ftid/lab/analyze.hpp): the refusal of
// a log too short for the analysis, with what would do, and `ftid analyze`'s reading of its logs,
// checked against lab::analyzeLogFiles (logio::readLog + samples::buildContexts) on the same files.
// Constructed contexts and 1 s simulator runs: fast.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <unistd.h>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/logio/log.hpp"
#include "lab_sim.hpp"
#include "test_paths.hpp"

namespace {

using namespace ftid;

/// `n` contexts; moving (|w_S| = 0.1 rad/s) or at rest, with a 'pose' column (pose of sample i:
/// i / per_pose) when per_pose > 0.
samples::ContextSet makeSet(std::size_t n, bool moving, std::size_t per_pose) {
  samples::ContextSet set;
  set.samples.resize(n);
  for (auto& c : set.samples) c.w_S = moving ? Vec3(0.0, 0.1, 0.0) : Vec3::Zero();
  if (per_pose > 0) {
    set.extra_names = {"pose"};
    for (std::size_t i = 0; i < n; ++i) set.extra_rows.push_back(static_cast<double>(i / per_pose));
  }
  set.repoint();
  return set;
}

std::string refusal(const samples::ContextSet& set, const lab::AnalyzeFilesRequest& req) {
  try {
    lab::checkEnoughSamples(set, req);
  } catch (const DataError& e) {
    return e.what();
  }
  return "";
}

lab::AnalyzeFilesRequest request(const std::string& log, int folds, const std::string& validate = "") {
  lab::AnalyzeFilesRequest req;
  req.log_path = log;
  req.validate_path = validate;
  req.options.folds = folds;
  return req;
}

TEST(CheckEnoughSamples, AMovingLogNeedsTwentyPerBlockAndIsToldWhatWouldDo) {
  EXPECT_EQ(refusal(makeSet(100, true, 0), request("fit.csv", 5)), "");
  EXPECT_EQ(refusal(makeSet(99, true, 0), request("fit.csv", 5)),
            "fit.csv: 99 samples are too few for the analysis (need 100: 20 per held-out block x 5 blocks). "
            "What would do: a longer recording; fewer held-out blocks (--folds 2 needs 40); a separate "
            "validation log (--validate LOG2: 20 samples each); or the identification alone: "
            "ftid identify --log fit.csv (docs/analyze.md)");
  // Two blocks: 40, and no fewer blocks to suggest.
  EXPECT_EQ(refusal(makeSet(40, true, 0), request("fit.csv", 2)), "");
  EXPECT_EQ(refusal(makeSet(39, true, 0), request("fit.csv", 2)),
            "fit.csv: 39 samples are too few for the analysis (need 40: 20 per held-out block x 2 blocks). "
            "What would do: a longer recording; a separate validation log (--validate LOG2: 20 samples each); "
            "or the identification alone: ftid identify --log fit.csv (docs/analyze.md)");
}

TEST(CheckEnoughSamples, AValidationLogNeedsTwentyWhateverTheBlocks) {
  EXPECT_EQ(refusal(makeSet(20, true, 0), request("fit.csv", 5, "val.csv")), "");
  EXPECT_EQ(refusal(makeSet(19, true, 0), request("fit.csv", 5, "val.csv")),
            "fit.csv: 19 samples are too few for the analysis (need 20). What would do: a longer recording; "
            "or the identification alone: ftid identify --log fit.csv (docs/analyze.md)");
}

TEST(CheckEnoughSamples, AStaticSetCountsItsPosesByThePoseColumn) {
  // 17 poses, two readings each: 34 samples, 6 a pose would make the 100.
  const std::string two_each = refusal(makeSet(34, false, 2), request("poses.csv", 5));
  EXPECT_EQ(two_each.rfind("poses.csv: 34 samples are too few for the analysis (need 100: 20 per held-out "
                           "block x 5 blocks). What would do: repeated readings at each pose (e.g. 6 at each "
                           "of the 17 poses, consecutive rows with a 'pose' column: their spread is the noise "
                           "floor) or more poses; fewer held-out blocks",
                           0),
            0u)
      << two_each;
  EXPECT_NE(two_each.find("ftid identify --log poses.csv --method static (docs/analyze.md)"), std::string::npos)
      << two_each;
  // Without a pose column every row is a pose; at least 2 readings a pose are asked for.
  const std::string no_column = refusal(makeSet(60, false, 0), request("poses.csv", 5));
  EXPECT_NE(no_column.find("(e.g. 2 at each of the 60 poses"), std::string::npos) << no_column;
  // One moving sample makes it a recording, not a pose set.
  samples::ContextSet moving = makeSet(34, false, 2);
  moving.samples[5].w_S = Vec3(0.0, 0.0, 2e-3);
  const std::string longer = refusal(moving, request("poses.csv", 5));
  EXPECT_NE(longer.find("What would do: a longer recording; "), std::string::npos) << longer;
  EXPECT_EQ(longer.find("--method static"), std::string::npos) << longer;
}

class AnalyzeRecordings : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir_template[] = "/tmp/ftid-analyze-recordings.XXXXXX";
    ASSERT_NE(mkdtemp(dir_template), nullptr);
    dir = dir_template;
  }
  void TearDown() override {
    for (const std::string& p : files) std::remove(p.c_str());
    rmdir(dir.c_str());
  }
  /// A simulated run of `duration_s` written as an ftid log; `extra` adds a constant extra column.
  std::string writeRun(const std::string& name, std::uint64_t seed, double duration_s, const std::string& extra = "") {
    sim::CellSimConfig cfg = labtest::baseConfig(seed);
    cfg.duration_s = duration_s;
    logio::LogData log = sim::CellSim(cfg).run();
    if (!extra.empty()) {
      log.extra_names.push_back(extra);
      log.extra_columns.emplace_back(log.samples.size(), 1.0);
    }
    const std::string path = dir + "/" + name;
    logio::writeLog(path, log);
    files.push_back(path);
    return path;
  }
  lab::AnalyzeFilesRequest request(const std::string& fit, const std::string& validate) {
    const sim::CellSimConfig cfg = labtest::baseConfig(1);
    lab::AnalyzeFilesRequest req;
    req.log_path = fit;
    req.validate_path = validate;
    req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
    req.context = {cfg.R_FS, cfg.p_FS_F, 0.0, 0.0};
    req.options.candidates = {"rigid_body", "poly(t,2)"};
    req.options.progress = [this](const std::string& line) { progress.push_back(line); };
    return req;
  }
  std::string dir;
  std::vector<std::string> files;
  std::vector<std::string> progress;
};

TEST_F(AnalyzeRecordings, ReadsAndAnalysesAsAnalyzeLogFiles) {
  const std::string fit = writeRun("fit.csv", 11, 1.0);
  const std::string val = writeRun("val.csv", 12, 1.0);
  const lab::AnalysisResult r = lab::analyzeRecordings(request(fit, val));
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.front(), "reading " + fit);
  const lab::AnalysisResult ref = lab::analyzeLogFiles(request(fit, val));
  EXPECT_EQ(r.robot_urdf, ref.robot_urdf);
  EXPECT_EQ(r.n_eval, ref.n_eval);
  EXPECT_GT(r.n_eval, 100);
  for (int a = 0; a < 6; ++a) EXPECT_DOUBLE_EQ(r.report.residual_rms(a), ref.report.residual_rms(a)) << a;
  ASSERT_EQ(r.candidates.size(), ref.candidates.size());
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    EXPECT_EQ(r.candidates[i].effect, ref.candidates[i].effect);
    EXPECT_DOUBLE_EQ(r.candidates[i].relative_reduction, ref.candidates[i].relative_reduction);
  }
}

TEST_F(AnalyzeRecordings, RefusesATooShortLogBeforeTheAnalysis) {
  const std::string fit = writeRun("short.csv", 13, 0.5);  // 63 samples at 125 Hz: 5 blocks need 100
  try {
    lab::analyzeRecordings(request(fit, ""));
    FAIL() << "no refusal";
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(fit + ": 63 samples are too few for the analysis (need 100", 0), 0u) << what;
  }
  // With a validation log 20 do, but its extra columns must be the fitted log's.
  const std::string other = writeRun("other.csv", 14, 0.5, "pose");
  try {
    lab::analyzeRecordings(request(fit, other));
    FAIL() << "no refusal";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()), other + ": its extra columns differ from those of " + fit);
  }
}

}  // namespace
