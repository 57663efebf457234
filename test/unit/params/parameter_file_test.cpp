// Parameter files (issue 14): strict reading (duplicate keys, non-positive mass, invalid inertia,
// FIFOs refused) and writing that refuses non-finite or unphysical values with the previous file
// and its .bak untouched.
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::params {
namespace {

std::string scratch(const std::string& name) {
  return std::string(FTID_BINARY_DIR) + "/param_file_test_" +
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
  EXPECT_NE(m.find(p + ":4: key 'parameters.mass': mass -0.5 kg is not positive"), std::string::npos) << m;
  spit(p, "model: paper\nparameters:\n  mass: {value: 0}\n");
  EXPECT_NE(errorOf(p).find("not positive"), std::string::npos);
  spit(p, "model: paper\nparameters:\n  mass: {value: .nan}\n");
  EXPECT_NE(errorOf(p).find("not finite"), std::string::npos) << errorOf(p);
  spit(p, "model: paper\nparameters:\n  mass: {value: 1, std: .inf}\n");
  EXPECT_NE(errorOf(p).find("parameters.mass.std"), std::string::npos) << errorOf(p);
  std::filesystem::remove(p);
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
  const std::string dir = std::string(FTID_BINARY_DIR);
  EXPECT_NE(errorOf(dir).find(dir + ": cannot read the parameter file: it is a directory"), std::string::npos)
      << errorOf(dir);
}

}  // namespace
}  // namespace ftid::params
