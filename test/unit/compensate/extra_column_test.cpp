// `ftid compensate` (compensateLogFile) of a model that reads an extra log column: a gripper jaw
// moving with `grip` (test/unit/lab/jaw_sim.hpp, its own physics), identified as
// paper+rigid_body+payload(grip) and compensated from the log's own column to the noise floor; a log
// without the column is refused with its name; ftidd, which has no extra columns at run time,
// refuses the parameter file (daemon test). docs/effects.md, "payload(s)".
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <unistd.h>

#include "../identify/paper_cell.hpp"
#include "../lab/jaw_sim.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensate_log.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/params/parameter_set.hpp"
#include "test_paths.hpp"

namespace ftid::compensate {
namespace {

struct Scratch {
  std::string dir = ftid::test::binaryPath("/extra_column_test_") + std::to_string(::getpid());
  Scratch() { (void)std::system(("mkdir -p '" + dir + "'").c_str()); }
  ~Scratch() { (void)std::system(("rm -rf '" + dir + "'").c_str()); }
};

constexpr double kForceNoise = 0.05;   // [N]
constexpr double kTorqueNoise = 0.01;  // [Nm]

struct JawRun {
  sim::CellSimConfig cfg = test::paperConfig(true, 4401);
  logio::LogData log;
  JawRun() {
    cfg.full_rigid_body = true;
    cfg.noise.wrench_std << kForceNoise, kForceNoise, kForceNoise, kTorqueNoise, kTorqueNoise, kTorqueNoise;
    const sim::CellSim s(cfg);
    log = s.run();
    jawtest::addJaw(s, log);
  }
};

/// Identifies `model` on the run and writes its parameter file; returns the path.
std::string identifyTo(const JawRun& run, const std::string& model, const std::string& path) {
  const samples::ContextSet ctx = samples::buildContexts(run.log, *run.cfg.robot);
  const identify::FitResult fit = identify::fitModel(effects::Model::fromName(model), ctx.samples);
  params::writeParameterFile(path, identify::toParameterSet(fit));
  return path;
}

CompensateSummary compensate(const Scratch& s, const std::string& log_path, const std::string& params_path) {
  CompensateRequest r;
  r.log_path = log_path;
  r.params_path = params_path;
  r.out_csv = s.dir + "/contact.csv";
  r.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  return compensateLogFile(r);
}

TEST(ExtraColumnCompensation, APayloadMovingWithALogColumnIsCompensatedFromTheLog) {
  const Scratch s;
  const JawRun run;
  const std::string log_path = s.dir + "/jaw.csv";
  logio::writeLog(log_path, run.log);
  const Vec6 noise = (Vec6() << kForceNoise, kForceNoise, kForceNoise, kTorqueNoise, kTorqueNoise, kTorqueNoise).finished();
  const auto with = compensate(s, log_path, identifyTo(run, "paper+rigid_body+payload(grip)", s.dir + "/with.yaml"));
  ASSERT_GT(with.n_samples, 1000);
  for (int a = 0; a < 6; ++a) EXPECT_LE(with.contact_rms(a), 1.2 * noise(a)) << kWrenchAxisNames[a];
  // Without the effect the jaw is left in the contact wrench (and the fit is not physical: no
  // parameter file, so the set goes in directly): the column is what compensates it.
  CompensateRequest r;
  r.log_path = log_path;
  r.params_path = "(paper+rigid_body)";
  r.out_csv = s.dir + "/contact_without.csv";
  r.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  const samples::ContextSet ctx = samples::buildContexts(run.log, *run.cfg.robot);
  const auto without = compensateLogFile(
      r, identify::toParameterSet(identify::fitModel(effects::Model::fromName("paper+rigid_body"), ctx.samples)));
  EXPECT_GT(without.contact_rms.tail<3>().maxCoeff(), 2.0 * kTorqueNoise) << without.contact_rms.transpose();
}

TEST(ExtraColumnCompensation, ALogWithoutTheColumnIsRefusedByName) {
  const Scratch s;
  JawRun run;
  const std::string params = identifyTo(run, "paper+rigid_body+payload(grip)", s.dir + "/p.yaml");
  run.log.extra_names.clear();
  run.log.extra_columns.clear();
  const std::string log_path = s.dir + "/no_grip.csv";
  logio::writeLog(log_path, run.log);
  try {
    (void)compensate(s, log_path, params);
    FAIL() << "compensated without the column";
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'grip'"), std::string::npos) << what;
    EXPECT_NE(what.find("no_grip.csv"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace ftid::compensate
