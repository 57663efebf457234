// Parameter files (issue 14): strict reading (duplicate keys, non-positive mass, invalid inertia,
// FIFOs refused) and writing that refuses non-finite or unphysical values with the previous file
// and its .bak untouched.
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/params/parameter_set.hpp"
#include "test_paths.hpp"

namespace ftid::params {
namespace {

std::string scratch(const std::string& name) {
  return ftid::test::binaryPath("/param_file_test_") +
         ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" + name;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void spit(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

std::string errorOf(const std::string& path) {
  try {
    (void)readParameterFile(path);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

ParameterSet paperSet(double mass) {
  ParameterSet s;
  s.model = "paper";
  s.params = {{"mass", mass, 0.001, "kg"},        {"mass_com_x", 0.004, 1e-4, "kg*m"},
              {"mass_com_y", 0.002, 1e-4, "kg*m"}, {"mass_com_z", 0.046, 1e-4, "kg*m"},
              {"f0_x", 0.1, 0.01, "N"},            {"f0_y", -0.2, 0.01, "N"},
              {"f0_z", 0.35, 0.01, "N"}};
  s.residual_rms << 0.1, 0.1, 0.1, 0.01, 0.01, 0.01;
  s.condition_number = 12.0;
  return s;
}

TEST(ParameterFile, RoundTripOfAValidSet) {
  const std::string p = scratch("p.yaml");
  std::filesystem::remove(p);
  writeParameterFile(p, paperSet(0.9));
  const ParameterSet back = readParameterFile(p);
  ASSERT_NE(back.find("mass"), nullptr);
  EXPECT_EQ(back.find("mass")->value, 0.9);
  std::filesystem::remove(p);
}

// The YAML emitter's number policy (ftid/fileio/yaml_emit.hpp): every double reads back bit for
// bit, including values with no short decimal form, tiny and huge magnitudes and negative zero.
TEST(ParameterFile, EveryDoubleRoundTripsBitForBit) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  const auto awkward = [&] { return std::ldexp(mantissa(rng), exponent(rng) / 10); };
  for (int trial = 0; trial < 20; ++trial) {
    ParameterSet s = paperSet(0.1 + std::abs(mantissa(rng)));
    for (auto& p : s.params) {
      if (p.name != "mass") p.value = awkward();
      p.std = std::abs(awkward());
    }
    s.params.push_back({"t0_x", 1e-300, 4.9406564584124654e-324, "Nm"});  // a subnormal std
    s.params.push_back({"t0_y", -0.0, 1e300, "Nm"});
    s.params.push_back({"t0_z", 1.0 / 3.0, 0.1, "Nm"});
    s.tilt_u_rad = awkward();
    s.tilt_v_rad = awkward();
    s.tilt_u_std = std::abs(awkward());
    for (int a = 0; a < 6; ++a) s.residual_rms(a) = std::abs(awkward());
    s.condition_number = 1.0 + std::abs(awkward());
    s.provenance.data_file = "runs/a: b # not a comment.csv";  // YAML-significant characters
    const std::string path = scratch("bits.yaml");
    std::filesystem::remove(path);
    writeParameterFile(path, s);
    const ParameterSet back = readParameterFile(path);
    ASSERT_EQ(back.params.size(), s.params.size());
    for (std::size_t k = 0; k < s.params.size(); ++k) {
      EXPECT_EQ(back.params[k].name, s.params[k].name);
      EXPECT_EQ(std::memcmp(&back.params[k].value, &s.params[k].value, sizeof(double)), 0)
          << s.params[k].name << " " << s.params[k].value << " -> " << back.params[k].value;
      EXPECT_EQ(std::memcmp(&back.params[k].std, &s.params[k].std, sizeof(double)), 0) << s.params[k].name;
      EXPECT_EQ(back.params[k].unit, s.params[k].unit);
    }
    EXPECT_EQ(back.tilt_u_rad, s.tilt_u_rad);
    EXPECT_EQ(back.tilt_v_rad, s.tilt_v_rad);
    EXPECT_EQ(back.tilt_u_std, s.tilt_u_std);
    EXPECT_EQ(back.residual_rms, s.residual_rms);
    EXPECT_EQ(back.condition_number, s.condition_number);
    EXPECT_EQ(back.provenance.data_file, s.provenance.data_file);
    std::filesystem::remove(path);
    std::filesystem::remove(path + ".bak");
  }
}

TEST(ParameterFile, DuplicateMassKeyIsRefusedNamingTheLine) {
  const std::string p = scratch("dup.yaml");
  spit(p, "model: paper\nparameters:\n  mass: {value: 0.9}\n  mass: {value: 9.0}\n");
  const std::string m = errorOf(p);
  EXPECT_NE(m.find(p + ":4: duplicate key 'mass' (first on line 3)"), std::string::npos) << m;
  std::filesystem::remove(p);
}

TEST(ParameterFile, NonPositiveMassAndNonFiniteValuesAreRefused) {
  const std::string p = scratch("neg.yaml");
  spit(p, "model: paper\nparameters:\n  f0_x: {value: 0.1}\n  mass: {value: -0.5, std: 0.01}\n");
  const std::string m = errorOf(p);
  EXPECT_NE(m.find(p + ":4:9: key 'parameters.mass': mass -0.5 kg is not positive"), std::string::npos) << m;
  spit(p, "model: paper\nparameters:\n  mass: {value: 0}\n");
  EXPECT_NE(errorOf(p).find("not positive"), std::string::npos);
  spit(p, "model: paper\nparameters:\n  mass: {value: .nan}\n");
  EXPECT_NE(errorOf(p).find(p + ":3:17: key 'parameters.mass.value': must be finite"), std::string::npos) << errorOf(p);
  spit(p, "model: paper\nparameters:\n  mass: {value: 1, std: .inf}\n");
  EXPECT_NE(errorOf(p).find("parameters.mass.std"), std::string::npos) << errorOf(p);
  std::filesystem::remove(p);
}

TEST(ParameterFile, BadValuesAndUnknownKeysNameFileLineColumnAndKey) {
  const std::string p = scratch("bad.yaml");
  const auto expectError = [&](const std::string& text, const std::string& fragment) {
    spit(p, text);
    const std::string m = errorOf(p);
    EXPECT_NE(m.find(p + fragment), std::string::npos) << m;
  };
  expectError("model: paper\nparameters:\n  mass: {value: heavy}\n",
              ":3:17: key 'parameters.mass.value': expected a number, got 'heavy'");
  expectError("model: paper\nparameters:\n  mass: {value: 1, sdt: 0.1}\n",
              ":3:20: key 'parameters.mass.sdt': unknown key (known keys here: value, std, unit)");
  expectError("model: paper\nparameters:\n  mass: {std: 0.1}\n", ":3:9: key 'parameters.mass.value': missing");
  expectError("model: paper\nparameters:\n  mass: {value: 1}\ntilt:\n  estimated: maybe\n",
              ":5:14: key 'tilt.estimated': expected true or false, got 'maybe'");
  expectError("model: paper\nparameters:\n  mass: {value: 1}\nprovenance:\n  n_samples: 12.5\n",
              ":5:14: key 'provenance.n_samples': expected an integer, got '12.5'");
  expectError("model: paper\nparamters:\n  mass: {value: 1}\n", ":2:1: key 'paramters': unknown key");
  expectError("model: paper\n", ": key 'parameters': missing");
  std::filesystem::remove(p);
}

// The IMU's biases (compensation with the motion from the IMU): written, read back bit for bit,
// zero where absent, strict keys, and a bias no working IMU has is refused naming the key.
TEST(ParameterFile, ImuBiasesRoundTripAndAreChecked) {
  const std::string p = scratch("imu.yaml");
  std::filesystem::remove(p);
  ParameterSet set = paperSet(0.9);
  EXPECT_EQ(imuBiasesOf(set), Vec6::Zero());
  set.imu = {{"gyro_bias_x", 0.0021, 1e-5, "rad/s"}, {"gyro_bias_y", -0.0029, 1e-5, "rad/s"},
             {"gyro_bias_z", 0.0011, 1e-5, "rad/s"}, {"acc_bias_z", 0.037, 1e-3, "m/s^2"}};
  writeParameterFile(p, set);
  const ParameterSet back = readParameterFile(p);
  Vec6 expected;
  expected << 0.0, 0.0, 0.037, 0.0021, -0.0029, 0.0011;
  EXPECT_EQ(imuBiasesOf(back), expected);
  ASSERT_EQ(back.imu.size(), 4u);
  const std::string head = "model: paper\nparameters:\n  mass: {value: 1}\n";
  spit(p, head + "imu:\n  gyro_bias_w: {value: 0.001}\n");
  EXPECT_NE(errorOf(p).find(":5:3: key 'imu.gyro_bias_w': unknown key"), std::string::npos) << errorOf(p);
  spit(p, head + "imu:\n  acc_bias_x: {value: 9.81}\n");
  EXPECT_NE(errorOf(p).find("key 'imu.acc_bias_x': bias 9.81 m/s^2 is beyond 2 (no working IMU"), std::string::npos)
      << errorOf(p);
  spit(p, head + "imu:\n  gyro_bias_x: {value: 0.5}\n");
  EXPECT_NE(errorOf(p).find("key 'imu.gyro_bias_x': bias 0.5 rad/s is beyond 0.2 (no working IMU"), std::string::npos) << errorOf(p);
  std::filesystem::remove(p);
  std::filesystem::remove(p + ".bak");
}

TEST(ParameterFile, InvalidInertiaIsRefused) {
  ParameterSet s = paperSet(1.0);
  // I_S about the S origin with the com at ~5 cm: a valid tensor first ...
  for (const auto& [n, v] : {std::pair<const char*, double>{"i_s_xx", 0.01}, {"i_s_yy", 0.01}, {"i_s_zz", 0.002},
                             {"i_s_xy", 0.0}, {"i_s_xz", 0.0}, {"i_s_yz", 0.0}}) {
    s.params.push_back({n, v, 0.0, "kg*m^2"});
  }
  EXPECT_FALSE(findParameterProblem(s).has_value()) << findParameterProblem(s)->message;
  // ... then one violating the triangle inequality (zz > xx + yy about the com).
  for (auto& p : s.params) {
    if (p.name == "i_s_zz") p.value = 0.05;
  }
  const auto problem = findParameterProblem(s);
  ASSERT_TRUE(problem.has_value());
  EXPECT_NE(problem->message.find("invalid inertia"), std::string::npos) << problem->message;
  const std::string p = scratch("inertia.yaml");
  std::filesystem::remove(p);
  EXPECT_THROW(writeParameterFile(p, s), IdentificationError);
  EXPECT_FALSE(std::filesystem::exists(p));
}

// Issue 14: a log with tz = -1e300 made `identify --out` write `null`s and rotate the valid file
// to .bak. Whatever produces such a set, the writer refuses it and touches nothing.
TEST(ParameterFile, WriterRefusesNonFiniteAndLeavesPreviousFileAndBackupUntouched) {
  const std::string p = scratch("params.yaml");
  std::filesystem::remove(p);  // leftovers of an interrupted run would be rotated into .bak
  std::filesystem::remove(p + ".bak");
  writeParameterFile(p, paperSet(0.9));
  const std::string before = slurp(p);
  for (int variant = 0; variant < 4; ++variant) {
    ParameterSet bad = paperSet(0.9);
    if (variant == 0) bad.params[6].value = std::nan("");
    if (variant == 1) bad.params[0].value = -0.9;
    if (variant == 2) bad.residual_rms(5) = INFINITY;
    if (variant == 3) bad.tilt_u_rad = std::nan("");
    try {
      writeParameterFile(p, bad);
      FAIL() << "variant " << variant;
    } catch (const IdentificationError& e) {
      EXPECT_NE(std::string(e.what()).find(p + ": not written"), std::string::npos) << e.what();
    }
    EXPECT_EQ(slurp(p), before) << "variant " << variant;
    EXPECT_FALSE(std::filesystem::exists(p + ".bak")) << "variant " << variant << " rotated the backup";
  }
  // A valid write rotates the previous file into .bak.
  writeParameterFile(p, paperSet(1.1));
  EXPECT_EQ(slurp(p + ".bak"), before);
  std::filesystem::remove(p);
  std::filesystem::remove(p + ".bak");
}

TEST(ParameterFile, FifoAndDirectoryAreRefusedWithoutBlocking) {
  const std::string fifo = scratch("fifo.yaml");
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(errorOf(fifo).find(fifo + ": cannot read the parameter file: it is a FIFO"), std::string::npos)
      << errorOf(fifo);
  std::filesystem::remove(fifo);
  const std::string dir = ftid::test::binaryDir();
  EXPECT_NE(errorOf(dir).find(dir + ": cannot read the parameter file: it is a directory"), std::string::npos)
      << errorOf(dir);
}

}  // namespace
}  // namespace ftid::params
