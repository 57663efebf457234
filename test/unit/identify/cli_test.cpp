// `ftid identify` / `ftid compensate` end to end on simulated logs: JSON output, parameter file,
// compensated CSV, and the one-line errors with non-zero exit codes for bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"

namespace {

struct CliRun {
  int code = -1;
  std::string out;
  std::string err;
};

// CTest runs each test of this file as its own process, in parallel: every file a test writes
// (including the captured stderr) carries the test's name so two tests never share one.
std::string dir() {
  return std::string(FTID_BINARY_DIR) + "/identify_cli_test_" +
         ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_";
}

CliRun ftidRun(const std::string& args) {
  const std::string err_file = dir() + "stderr.txt";
  const std::string cmd = "cd " + std::string(FTID_SOURCE_DIR) + " && " + FTID_BINARY_DIR + "/apps/ftid/ftid " +
                          args + " 2>" + err_file;
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream e(err_file);
  std::stringstream ss;
  ss << e.rdbuf();
  r.err = ss.str();
  return r;
}

double jsonValue(const std::string& json, const std::string& key) {
  const std::string pat = "\"" + key + "\":{\"value\":";
  const auto at = json.find(pat);
  if (at == std::string::npos) return std::nan("");
  return std::stod(json.substr(at + pat.size()));
}

TEST(IdentifyCli, JsonParamsAndCompensation) {
  const std::string log_path = dir() + "run.csv";
  ftid::logio::writeLog(log_path, ftid::sim::CellSim(ftid::test::paperConfig(true, 9)).run());
  const std::string params = dir() + "params.yaml";
  const CliRun r = ftidRun("identify --log " + log_path + " --json --out " + params);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(jsonValue(r.out, "weight"), 8.862, 0.05) << r.out;
  EXPECT_NEAR(jsonValue(r.out, "com_z"), 0.051, 0.002) << r.out;
  EXPECT_NE(r.out.find("\"residual_rms\":{\"fx\":"), std::string::npos);

  const CliRun t = ftidRun("identify --log " + log_path + " --method static");
  ASSERT_EQ(t.code, 0) << t.err;
  EXPECT_NE(t.out.find("residual RMS"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("condition number"), std::string::npos) << t.out;

  const std::string out_csv = dir() + "contact.csv";
  const CliRun c = ftidRun("compensate --log " + log_path + " --params " + params + " --out " + out_csv);
  ASSERT_EQ(c.code, 0) << c.err;
  const ftid::logio::LogData log = ftid::logio::readLog(log_path);
  std::ifstream in(out_csv);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("t,fx,fy,fz,tx,ty,tz,model_fx", 0), 0u) << header;
  std::size_t rows = 0;
  double worst = 0.0;
  while (std::getline(in, line)) {
    ++rows;
    std::stringstream ss(line);
    std::string cell;
    std::getline(ss, cell, ',');
    std::getline(ss, cell, ',');  // fx of the contact wrench
    worst = std::max(worst, std::abs(std::stod(cell)));
  }
  EXPECT_EQ(rows, log.samples.size());
  EXPECT_LT(worst, 0.3);  // noise 0.05 N: nothing but noise left
}

TEST(IdentifyCli, BadInputGivesOneLineAndNonZeroExit) {
  const std::string bad = dir() + "bad.csv";
  {
    ftid::logio::LogData log = ftid::sim::CellSim(ftid::test::paperConfig(false, 9)).run();
    log.samples.resize(50);
    ftid::logio::writeLog(bad, log);
  }
  // Corrupt one value on line 5.
  std::ifstream in(bad);
  std::stringstream all;
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (++k == 5) line = "nan" + line.substr(line.find(','));
    all << line << "\n";
  }
  in.close();
  std::ofstream(bad) << all.str();
  const CliRun r = ftidRun("identify --log " + bad);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
  // Progress lines may precede it; the error itself is exactly one line, the last one.
  const auto error_at = r.err.find("ftid identify: error: ");
  ASSERT_NE(error_at, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n', error_at), r.err.size() - 1) << r.err;

  const CliRun missing = ftidRun("identify --log " + dir() + "nope.csv --json");
  EXPECT_EQ(missing.code, 1);
  const CliRun usage = ftidRun("identify");
  EXPECT_EQ(usage.code, 2);
  const CliRun method = ftidRun("identify --log " + bad + " --method fast");
  EXPECT_EQ(method.code, 2);

  // One pose only: the data do not determine the parameters.
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(false, 9);
  cfg.motion = [](double) {
    ftid::trajectory::TrajectoryPoint p;
    p.q = ftid::sim::paperStartPose();
    return p;
  };
  cfg.duration_s = 2.0;
  const std::string still = dir() + "still.csv";
  ftid::logio::writeLog(still, ftid::sim::CellSim(cfg).run());
  const CliRun s = ftidRun("identify --log " + still + " --json");
  EXPECT_EQ(s.code, 1);
  EXPECT_NE(s.err.find("do not determine"), std::string::npos) << s.err;
  EXPECT_EQ(std::count(s.err.begin(), s.err.end(), '\n'), 1) << s.err;
}

bool exists(const std::string& path) { return std::ifstream(path).good(); }

// Issue 26: nothing is written for a log with a wrong scale; a bad config does not stop offline
// work (only the plausibility inputs are read, defaults otherwise, and the limits are named).
TEST(IdentifyCli, OutRefusesAnImplausibleSetAndABadConfigMeansDefaults) {
  ftid::logio::LogData log = ftid::sim::CellSim(ftid::test::paperConfig(true, 9)).run();
  const std::string good_log = dir() + "good.csv";
  ftid::logio::writeLog(good_log, log);
  for (auto& sample : log.samples) sample.wrench_S(2) *= 4000.0;
  const std::string scaled = dir() + "scaled.csv";
  ftid::logio::writeLog(scaled, log);
  const std::string out = dir() + "scaled_params.yaml";
  std::remove(out.c_str());
  const CliRun r = ftidRun("identify --log " + scaled + " --out " + out);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_FALSE(exists(out));
  EXPECT_NE(r.err.find("not written"), std::string::npos) << r.err;

  const std::string bad_config = dir() + "bad_ftidd.yaml";
  std::ofstream(bad_config) << "robot:\n  rated_payload_kg: 12.5\n  no_such_key: 1\n";  // invalid as a whole
  const std::string good_out = dir() + "good_params.yaml";
  const CliRun g = ftidRun("identify --log " + good_log + " --out " + good_out + " --config " + bad_config);
  EXPECT_EQ(g.code, 0) << g.err;
  EXPECT_TRUE(exists(good_out));
  EXPECT_NE(g.err.find("rated payload 12.5 kg (" + bad_config + ": robot.rated_payload_kg)"), std::string::npos) << g.err;
  const CliRun none = ftidRun("identify --log " + good_log + " --out " + good_out + " --config " + dir() + "absent.yaml");
  EXPECT_EQ(none.code, 0) << none.err;
  EXPECT_NE(none.err.find("rated payload 10 kg (the built-in default"), std::string::npos) << none.err;

  // ftid compensate: same config handling; refuses an impossible or implausible parameter file.
  const std::string csv = dir() + "contact.csv";
  const CliRun c = ftidRun("compensate --log " + good_log + " --params " + good_out + " --out " + csv + " --config " +
                           bad_config);
  EXPECT_EQ(c.code, 0) << c.err;
  // Hand edits of the written file: the mass set to 10^6 kg (physically possible, beyond the
  // robot); and a rigid-body set with i_s_xx = -5, standard error 100 (the case).
  std::stringstream written;
  written << std::ifstream(good_out).rdbuf();
  std::string heavy_text = written.str();
  const std::string mass_key = "\n  mass: {value: ";
  const auto at = heavy_text.find(mass_key);
  ASSERT_NE(at, std::string::npos) << heavy_text;
  const auto value_at = at + mass_key.size();
  heavy_text.replace(value_at, heavy_text.find_first_of(",}", value_at) - value_at, "1e6");
  const std::string heavy = dir() + "heavy.yaml";
  std::ofstream(heavy) << heavy_text;
  const std::string negative = dir() + "negative_inertia.yaml";
  std::ofstream(negative) << "model: paper+rigid_body\nparameters:\n  mass: {value: 0.9, std: 0.01}\n"
                             "  mass_com_z: {value: 0.045, std: 0.001}\n  i_s_xx: {value: -5, std: 100}\n"
                             "  i_s_yy: {value: 0.01, std: 0.001}\n  i_s_zz: {value: 0.002, std: 0.001}\n"
                             "  i_s_xy: {value: 0}\n  i_s_xz: {value: 0}\n  i_s_yz: {value: 0}\n";
  for (const auto& [file, key] : {std::pair<std::string, std::string>{negative, "parameters.i_s_xx': invalid inertia"}, {heavy, "mass"}}) {
    std::remove(csv.c_str());
    const CliRun x = ftidRun("compensate --log " + good_log + " --params " + file + " --out " + csv);
    EXPECT_EQ(x.code, 1) << key << ": " << x.err;
    EXPECT_NE(x.err.find(key), std::string::npos) << x.err;
    EXPECT_FALSE(exists(csv)) << key;
  }
}

}  // namespace
