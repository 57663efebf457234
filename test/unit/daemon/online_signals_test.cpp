// ftidd compensates from the kinematics, the time and the sensor's own channels; it never has a
// log's extra columns. A parameter file whose model reads one (e.g. the user's own effect
// expr(fz: grip*qd6), docs/effects.md) is refused at load, naming the file, the effect and the
// signal, instead of publishing nothing but invalid wrenches.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/compensate/compensate_log.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

params::ParameterSet setWith(const std::string& model, const std::string& extra_param) {
  params::ParameterSet set;
  set.model = model;
  for (const char* name : {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z", "mass_com_x", "mass_com_y", "mass_com_z"}) {
    set.params.push_back({name, 0.01, 0.0, ""});
  }
  set.params.push_back({"mass", 1.2, 0.0, ""});
  set.params.push_back({extra_param, 0.5, 0.0, ""});
  set.tilt_estimated = true;
  return set;
}

TEST(OnlineSignals, AModelReadingALogColumnIsRefusedAtLoad) {
  const params::ParameterSet set = setWith("paper+expr(fz: grip*qd6)", "expr_fz_grip_times_qd6");
  try {
    ParameterFileCompensation comp(set, "/etc/ftid/params.yaml");
    FAIL() << "loaded a model that reads the log column 'grip'";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/etc/ftid/params.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find("ftidd does not receive"), std::string::npos) << what;
    EXPECT_NE(what.find("'grip'"), std::string::npos) << what;
  }
}

TEST(OnlineSignals, AnExpressionOfTheKinematicsLoadsAndCompensates) {
  const params::ParameterSet set = setWith("paper+expr(fz: sin(q6)*wz)", "expr_fz_sin_q6_times_wz");
  ParameterFileCompensation comp(set, "params.yaml");
  effects::SampleContext ctx;
  ctx.q(5) = 0.5;
  ctx.w_S.z() = 2.0;
  Wrench contact = Wrench::Zero();
  Wrench modelled = Wrench::Zero();
  ASSERT_TRUE(comp.compute(ctx, &contact, &modelled));
  // modelled fz = f0_z + m g_z + 0.5 sin(q6) wz (S level with the base, zero tilt, at rest).
  EXPECT_NEAR(modelled(2), 0.01 - 1.2 * 9.80665 + 0.5 * std::sin(0.5) * 2.0, 1e-9);
}

// Offline, the same file compensates a log that has the column: a simulated run (the paper's
// physics, exact for `paper`) with fz += 2 grip qd6 written into it leaves only the noise; a log
// without `grip` is refused naming the log, the effect and the signal.
TEST(OnlineSignals, OfflineCompensationUsesTheLogColumnAndRefusesALogWithoutIt) {
  sim::CellSimConfig c = sim::paperCellConfig(model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf")));
  c.full_rigid_body = false;
  c.duration_s = 4.0;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  logio::LogData log = sim::CellSim(c).run();
  std::vector<double> grip(log.samples.size());
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    grip[i] = 0.5 + 0.5 * std::sin(1.3 * log.samples[i].t);
    log.samples[i].wrench_S(2) += 2.0 * grip[i] * log.samples[i].qd(5);
  }
  const std::string dir = "/tmp/ftid_online_signals_" + std::to_string(::getpid());
  ASSERT_EQ(std::system(("mkdir -p " + dir).c_str()), 0);
  logio::writeLog(dir + "/without.csv", log);
  log.extra_names.push_back("grip");
  log.extra_columns.push_back(grip);
  logio::writeLog(dir + "/with.csv", log);

  params::ParameterSet set = setWith("paper+expr(fz: grip*qd6)", "expr_fz_grip_times_qd6");
  set.params.clear();
  const auto add = [&](const std::string& name, double v) { set.params.push_back({name, v, 0.0, ""}); };
  for (int k = 0; k < 3; ++k) {
    const std::string ax(1, static_cast<char>('x' + k));
    add("f0_" + ax, c.F0_N(k));
    add("t0_" + ax, c.T0_Nm(k));
    add("mass_com_" + ax, c.payload.mass_kg * c.payload.p_SC_S(k));
  }
  add("mass", c.payload.mass_kg);
  add("expr_fz_grip_times_qd6", 2.0);
  set.tilt_u_rad = c.tilt_u_rad;
  set.tilt_v_rad = c.tilt_v_rad;
  params::writeParameterFile(dir + "/p.yaml", set);

  compensate::CompensateRequest req;
  req.params_path = dir + "/p.yaml";
  req.out_csv = dir + "/out.csv";
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  req.log_path = dir + "/with.csv";
  const compensate::CompensateSummary s = compensate::compensateLogFile(req);
  EXPECT_EQ(s.n_samples, static_cast<int>(log.samples.size()));
  EXPECT_GT(s.raw_rms(2), 1.0);
  EXPECT_GT(s.contact_rms(2), 0.7 * c.noise.wrench_std(2)) << s.contact_rms.transpose();
  EXPECT_LT(s.contact_rms(2), 1.3 * c.noise.wrench_std(2)) << s.contact_rms.transpose();
  req.log_path = dir + "/without.csv";
  try {
    compensate::compensateLogFile(req);
    ADD_FAILURE() << "compensated a log without the column the model reads";
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("without.csv"), std::string::npos) << what;
    EXPECT_NE(what.find("expr(fz: grip*qd6) needs the signal 'grip'"), std::string::npos) << what;
  }
  EXPECT_EQ(std::system(("rm -rf " + dir).c_str()), 0);
}

}  // namespace
}  // namespace ftid::daemon
