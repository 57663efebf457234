// fitModel beyond Table 2: subsets, held-out prediction, fixed tilt, the model-derivative hook,
// crosstalk (against the simulator's matrix), generic effects on extra log columns, and parameter
// files / JSON.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"
#include "test_paths.hpp"

namespace ftid::identify {
namespace {

using test::Table2;

const samples::ContextSet& clean() {
  static const samples::ContextSet s = test::contextsOf(test::paperConfig(false, 11));
  return s;
}

TEST(FitModel, SubsetFitEqualsFitOfTheCopiedSubset) {
  std::vector<int> idx;
  std::vector<SampleContext> copy;
  for (int i = 100; i < 700; ++i) {
    idx.push_back(i);
    copy.push_back(clean().samples[static_cast<std::size_t>(i)]);
  }
  const Model model = Model::fromName("paper");
  const FitResult a = fitModel(model, clean().samples, idx);
  const FitResult b = fitModel(model, copy);
  EXPECT_EQ(a.n_samples, 600);
  EXPECT_LT((a.theta - b.theta).norm(), 1e-12);
  EXPECT_NEAR(a.tilt_u_rad, b.tilt_u_rad, 1e-14);
}

TEST(FitModel, PredictsHeldOutDataExactly) {
  std::vector<int> first, second;
  for (int i = 0; i < static_cast<int>(clean().size()); ++i) (i < 600 ? first : second).push_back(i);
  const Model model = Model::fromName("paper");
  const FitResult fit = fitModel(model, clean().samples, first);
  const auto pred = predictWrench(model, fit, clean().samples, second);
  ASSERT_EQ(pred.cols(), static_cast<Eigen::Index>(second.size()));
  double worst = 0.0;
  for (std::size_t k = 0; k < second.size(); ++k) {
    worst = std::max(worst, (pred.col(static_cast<Eigen::Index>(k)) - clean().samples[static_cast<std::size_t>(second[k])].wrench_S)
                                .cwiseAbs()
                                .maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(FitModel, GivenTiltWithoutTiltEffect) {
  FitOptions o;
  o.tilt_u_rad = Table2::u();
  o.tilt_v_rad = Table2::v();
  const FitResult fit = fitModel(Model::fromName("offsets+gravity+linear_inertia"), clean().samples, o);
  EXPECT_FALSE(fit.tilt_estimated);
  EXPECT_TRUE(fit.tilt_applied);
  EXPECT_NEAR(fit.value("mass"), Table2::mass(), 1e-9);
  EXPECT_NEAR(fit.value("com_z"), Table2::com().z(), 1e-9);
  // Wrong (level) tilt without the tilt effect: the fit cannot explain the data.
  FitOptions level;
  level.tilt_u_rad = 0.0;
  level.tilt_v_rad = 0.0;
  const FitResult bad = fitModel(Model::fromName("offsets+gravity+linear_inertia"), clean().samples, level);
  EXPECT_GT(bad.residual_rms.head<3>().maxCoeff(), 0.1);
}

// An fx gain error registered at run time, to test the kSignalModelWrench hook:
//   reading_fx = (1 + g) w_fx   ->   column of g: the modelled fx of the other effects.
class TestFxGain final : public effects::Effect {
 public:
  std::string name() const override { return "test_fx_gain"; }
  std::string description() const override { return "test: gain error of fx"; }
  std::vector<effects::ParamInfo> params() const override { return {{"test_fx_gain", "1", "fx gain error"}}; }
  std::uint32_t signals() const override { return effects::kSignalModelWrench; }
  void bind(const effects::ParamIndex& index) override { col_ = effects::requireColumn(index, "test_fx_gain", name()); }
  void addRegressor(const SampleContext& ctx,
                    Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) const noexcept override {
    Y(0, col_) += ctx.wrench_model_S(0);
  }
  std::unique_ptr<effects::Effect> clone() const override { return std::make_unique<TestFxGain>(*this); }

 private:
  int col_ = 0;
};

TEST(FitModel, ModelWrenchHookRecoversAGain) {
  effects::registerEffect("test_fx_gain", "test only", [](const std::string&) { return std::make_unique<TestFxGain>(); });
  sim::CellSimConfig cfg = test::paperConfig(false, 12);
  cfg.crosstalk.enabled = true;
  cfg.crosstalk.E = Mat6::Zero();
  cfg.crosstalk.E(0, 0) = 0.02;  // the simulator reads (I + E) load + offsets
  const samples::ContextSet s = test::contextsOf(cfg);
  const Model model = Model::fromName("paper+test_fx_gain");
  const FitResult fit = fitModel(model, s.samples);
  EXPECT_NEAR(fit.value("test_fx_gain"), 0.02, 1e-9);
  EXPECT_NEAR(fit.value("mass"), Table2::mass(), 1e-9);
  EXPECT_NEAR(fit.value("f0_x"), Table2::f0().x() / 1.02, 1e-9);  // (1 + g) F0' = F0
  EXPECT_LT(fit.residual_rms.maxCoeff(), 1e-9);
  // predictWrench evaluates the hook the same way (effects::ModelEvaluator).
  const auto pred = predictWrench(model, fit, s.samples);
  double worst = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    worst = std::max(worst, (pred.col(static_cast<Eigen::Index>(i)) - s.samples[i].wrench_S).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
}

// The exact delay (effects/nonlinear.hpp) on the simulator's delayed wrench stream (src/sim
// evaluates the physics at t - tau itself), for delays of either sign and far beyond the
// first-order approximation's range.
class ExactDelay : public ::testing::TestWithParam<double> {};

TEST_P(ExactDelay, RecoversTheSimulatorsDelayAndReachesTheNoiseFloor) {
  const double tau = GetParam();
  sim::CellSimConfig cfg = test::paperConfig(false, 31);
  cfg.sensor_delay.enabled = true;
  cfg.sensor_delay.tau_s = tau;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.005, 0.005, 0.005;
  const samples::ContextSet s = test::contextsOf(cfg);
  const Model model = Model::fromName("paper+sensor_delay");
  const FitResult fit = fitModel(model, s.samples);
  ASSERT_TRUE(fit.delay_estimated);
  // Within 4 reported standard errors, and the reported error is small.
  EXPECT_NEAR(fit.delay_s, tau, 4.0 * fit.delay_std + 1e-5) << "std " << fit.delay_std;
  EXPECT_LT(fit.delay_std, 1e-3);
  EXPECT_NEAR(fit.value("mass"), Table2::mass(), 5.0 * fit.stddev("mass"));
  // The residual is at the noise floor on every axis (linear interpolation of the kinematics at
  // 125 Hz costs far less than the noise).
  for (int a = 0; a < 6; ++a) {
    EXPECT_LT(fit.residual_rms(a), 1.1 * cfg.noise.wrench_std(a)) << kWrenchAxisNames[a];
  }
  EXPECT_GT(fit.n_excluded, 0);
  // Without the effect the same data leave a residual far above the noise (delays the motion
  // makes visible: 12 ms at this excitation's speed is close to the noise).
  if (std::abs(tau) >= 0.05) {
    const FitResult plain = fitModel(Model::fromName("paper"), s.samples);
    EXPECT_GT(plain.residual_rms.head<3>().maxCoeff(), 3.0 * cfg.noise.wrench_std(0));
  }
}

INSTANTIATE_TEST_SUITE_P(Delays, ExactDelay, ::testing::Values(0.012, 0.150, -0.080, 0.5));

int axisIndex(const std::string& name) {
  for (int a = 0; a < 6; ++a) {
    if (name == kWrenchAxisNames[a]) return a;
  }
  return -1;
}

TEST(FitModel, CrosstalkRecoversTheSimulatorsMatrix) {
  // The simulator reads (I + E) load + offsets (src/sim). Data and model:
  //  - full rigid-body physics and the rigid_body effect: with the paper's physics alone the
  //    reading is affine in g_S - a_S (24 numbers), too little for the 31 crosstalk parameters;
  //  - with rigid_body, a common gain of all six axes is the one direction of E that the payload
  //    parameters absorb (every one scales with it); the effect leaves out E(fz,fz), E(tz,tz) and
  //    the antisymmetric force-to-moment block. So the simulator's matrix is taken with
  //    E(tz,tz) = E(fz,fz) = n and a symmetric force-to-moment block, and then exactly
  //      reading = (I + E_fit) w',  I + E = (1 + n)(I + E_fit),
  //      w' = (1 + n) load + (I + E_fit)^{-1} offsets   (payload parameters scaled by 1 + n).
  sim::CellSimConfig cfg = test::paperConfig(false, 21);
  cfg.full_rigid_body = true;
  cfg.crosstalk.enabled = true;
  Mat6 E = sim::CrosstalkSwitch::defaultMatrix();
  E(5, 5) = E(2, 2);
  const Mat3 E_tf = E.bottomLeftCorner<3, 3>();
  E.bottomLeftCorner<3, 3>() = 0.5 * (E_tf + E_tf.transpose());
  cfg.crosstalk.E = E;
  const double n = E(2, 2);
  const Mat6 E_fit = (Mat6::Identity() + E) / (1.0 + n) - Mat6::Identity();
  const Wrench offsets_fit = (Mat6::Identity() + E_fit).inverse() * (Wrench() << Table2::f0(), Table2::t0()).finished();

  const samples::ContextSet s = test::contextsOf(cfg);
  const Model model = Model::fromName("paper+rigid_body+crosstalk");
  const FitResult fit = fitModel(model, s.samples);
  int checked = 0;
  for (const auto& p : fit.params) {
    if (p.name.rfind("xt_", 0) != 0) continue;
    const int r = axisIndex(p.name.substr(3, 2));
    const int c = axisIndex(p.name.substr(6, 2));
    ASSERT_GE(r, 0) << p.name;
    ASSERT_GE(c, 0) << p.name;
    EXPECT_NEAR(fit.value(p.name), E_fit(r, c), 1e-9) << p.name;
    ++checked;
  }
  EXPECT_EQ(checked, 31);
  const double m = (1.0 + n) * Table2::mass();
  EXPECT_NEAR(fit.value("mass"), m, 1e-9);
  EXPECT_NEAR(fit.value("com_x"), Table2::com().x(), 1e-9);
  EXPECT_NEAR(fit.value("com_y"), Table2::com().y(), 1e-9);
  EXPECT_NEAR(fit.value("com_z"), Table2::com().z(), 1e-9);
  const char* offset_names[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};
  for (int a = 0; a < 6; ++a) EXPECT_NEAR(fit.value(offset_names[a]), offsets_fit(a), 1e-9) << offset_names[a];
  EXPECT_NEAR(fit.tilt_u_rad, Table2::u(), 1e-9);
  EXPECT_NEAR(fit.tilt_v_rad, Table2::v(), 1e-9);
  EXPECT_LT(fit.residual_rms.maxCoeff(), 1e-9);
  // Without the effect the same data leave a crosstalk-sized residual.
  const FitResult plain = fitModel(Model::fromName("paper+rigid_body"), s.samples);
  EXPECT_GT(plain.residual_rms.maxCoeff(), 1e3 * fit.residual_rms.maxCoeff());
  // predictWrench fills the modelled wrench the same way.
  const auto pred = predictWrench(model, fit, s.samples);
  double worst = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    worst = std::max(worst, (pred.col(static_cast<Eigen::Index>(i)) - s.samples[i].wrench_S).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
}

std::string tempPath(const std::string& name) {
  return ftid::test::binaryPath("/identify_test_") + name;
}

TEST(IdentifyLogFile, GenericEffectOnAnExtraCsvColumn) {
  // A log with an extra column (a humidity probe) on which the reading depends quadratically,
  // written as CSV and identified the way `ftid identify --model` does.
  const sim::CellSimConfig cfg = test::paperConfig(false, 31);
  logio::LogData log = sim::CellSim(cfg).run();
  Vec6 c1, c2;
  c1 << 0.02, -0.03, 0.05, 0.002, -0.001, 0.003;
  c2 << -0.004, 0.003, 0.002, 0.0003, 0.0002, -0.0004;
  log.extra_names.push_back("humidity");
  log.extra_columns.emplace_back();
  for (auto& sample : log.samples) {
    const double h = 45.0 + 8.0 * std::sin(0.9 * sample.t) + 3.0 * std::cos(2.3 * sample.t);
    log.extra_columns.back().push_back(h);
    sample.wrench_S += c1 * (h - 40.0) + c2 * (h - 40.0) * (h - 40.0);
  }
  const std::string path = tempPath("GenericEffectOnAnExtraCsvColumn.csv");
  logio::writeLog(path, log);
  IdentifyRequest request;
  request.log_path = path;
  request.model = "paper+poly(humidity,2,40)";
  request.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  const ParameterSet set = identifyLogFile(request);
  std::remove(path.c_str());
  for (int a = 0; a < 6; ++a) {
    const std::string ax = kWrenchAxisNames[a];
    const NamedValue* p1 = set.find("poly_humidity_1_" + ax);
    const NamedValue* p2 = set.find("poly_humidity_2_" + ax);
    ASSERT_NE(p1, nullptr) << ax;
    ASSERT_NE(p2, nullptr) << ax;
    EXPECT_NEAR(p1->value, c1(a), 1e-6) << ax;
    EXPECT_NEAR(p2->value, c2(a), 1e-7) << ax;
  }
  EXPECT_NEAR(set.find("mass")->value, Table2::mass(), 1e-6);
  EXPECT_LT(set.residual_rms.maxCoeff(), 1e-5);
}

TEST(FitModel, NonFiniteInputIsADataError) {
  std::vector<SampleContext> c = clean().samples;
  c[17].wrench_S(3) = std::nan("");
  EXPECT_THROW(fitModel(Model::fromName("paper"), c), DataError);
}

TEST(FitModel, NonFiniteInputNamesTheFirstBadSample) {
  // Every field the check covers, with +inf, -inf and NaN, in two samples: the first is named.
  // Samples 40 and 90 are read only by the compressed tilt search's pass; 38 and 57 are also
  // among its probe samples (every 19th of 1,251), where a non-finite value can fail the affine
  // test first and send the fit to the general path's check.
  ASSERT_EQ(clean().size(), 1251u);
  const std::vector<std::function<void(SampleContext&, double)>> fields = {
      [](SampleContext& x, double v) { x.wrench_S(4) = v; }, [](SampleContext& x, double v) { x.R_BS(1, 2) = v; },
      [](SampleContext& x, double v) { x.w_S(0) = v; },      [](SampleContext& x, double v) { x.alpha_S(2) = v; },
      [](SampleContext& x, double v) { x.a_S(1) = v; },      [](SampleContext& x, double v) { x.g_S(0) = v; },
      [](SampleContext& x, double v) { x.t = v; },           [](SampleContext& x, double v) { x.t_model = v; },
      [](SampleContext& x, double v) { x.imu_acc_S(2) = v; },
      [](SampleContext& x, double v) { x.imu_w_S(1) = v; },  [](SampleContext& x, double v) { x.imu_alpha_S(0) = v; },
      [](SampleContext& x, double v) { x.temp_degC = v; }};
  const double inf = std::numeric_limits<double>::infinity();
  for (const auto& [first, second] : {std::pair<std::size_t, std::size_t>{40, 90}, {38, 57}}) {
    for (std::size_t f = 0; f < fields.size(); ++f) {
      for (const double bad : {inf, -inf, std::nan("")}) {
        SCOPED_TRACE(std::to_string(first) + ": " + std::to_string(f) + " " + std::to_string(bad));
        std::vector<SampleContext> c = clean().samples;
        fields[f](c[first], bad);
        fields[f](c[second], bad);
        try {
          (void)fitModel(Model::fromName("paper"), c);
          ADD_FAILURE() << "no DataError";
        } catch (const DataError& e) {
          EXPECT_NE(std::string(e.what()).find("sample " + std::to_string(first) + " ("), std::string::npos)
              << e.what();
        }
      }
    }
  }
}

TEST(ParameterFile, RoundTripKeepsBackupAndNamesBadKeys) {
  const FitResult fit = fitModel(Model::fromName("paper"), clean().samples);
  ParameterSet set = toParameterSet(fit);
  set.provenance.data_file = "sim \"quoted\".csv";
  const std::string path = tempPath("params.yaml");
  std::remove(path.c_str());
  std::remove((path + ".bak").c_str());
  params::writeParameterFile(path, set);
  EXPECT_FALSE(std::ifstream(path + ".bak").good());
  params::writeParameterFile(path, set);
  EXPECT_TRUE(std::ifstream(path + ".bak").good());
  const ParameterSet back = params::readParameterFile(path);
  EXPECT_EQ(back.model, "paper");
  EXPECT_EQ(back.provenance.data_file, set.provenance.data_file);
  const Model model = Model::fromName(back.model);
  EXPECT_LT((thetaFor(model, back) - fit.theta).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(back.tilt_u_rad, fit.tilt_u_rad);
  EXPECT_DOUBLE_EQ(back.find("com_z")->value, fit.value("com_z"));
  EXPECT_DOUBLE_EQ(back.residual_rms(4), fit.residual_rms(4));

  const std::string bad = tempPath("bad.yaml");
  std::ofstream(bad) << "model: paper\nparameters:\n  mass: {value: heavy}\n";
  try {
    (void)params::readParameterFile(bad);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("parameters.mass.value"), std::string::npos) << e.what();
  }
  std::ofstream(bad) << "model: paper\nparameters:\n  mass: {value: 1.0}\n";
  const ParameterSet partial = params::readParameterFile(bad);
  try {
    (void)thetaFor(model, partial, bad);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("parameters.f0_x"), std::string::npos) << e.what();
  }
  EXPECT_THROW(params::readParameterFile(tempPath("does_not_exist.yaml")), ConfigError);
}

TEST(Json, HasTheDocumentedKeys) {
  const FitResult fit = fitModel(Model::fromName("paper"), clean().samples);
  const std::string j = toJson(toParameterSet(fit));
  for (const char* key : {"mass", "weight", "com_x", "com_y", "com_z", "f0_x", "f0_y", "f0_z", "t0_x", "t0_y",
                          "t0_z", "tilt_u", "tilt_v"}) {
    EXPECT_NE(j.find(std::string("\"") + key + "\":{\"value\":"), std::string::npos) << key;
  }
  EXPECT_NE(j.find("\"residual_rms\":{\"fx\":"), std::string::npos);
  EXPECT_NE(j.find("\"condition_number\":"), std::string::npos);
  int depth = 0;
  for (char c : j) {
    depth += (c == '{') - (c == '}');
    ASSERT_GE(depth, 0);
  }
  EXPECT_EQ(depth, 0);
  EXPECT_EQ(j.find("nan"), std::string::npos);
}

}  // namespace
}  // namespace ftid::identify
