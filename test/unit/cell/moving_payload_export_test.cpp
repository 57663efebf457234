// The UR and ros2_control exports of a model whose payload moves with a signal (payload(grip),
// docs/effects.md) say that they hold the payload at the signal's reference value only; a fixed
// payload's exports say nothing of the kind.
#include <gtest/gtest.h>

#include <string>

#include "ftid/cell/exports.hpp"
#include "ftid/params/parameter_set.hpp"

namespace {

ftid::params::ParameterSet setOf(const std::string& model) {
  ftid::params::ParameterSet set;
  set.model = model;
  set.params = {{"mass", 0.9, 0.001, "kg"}};
  set.derived = {{"com_x", 0.01, 1e-4, "m"}, {"com_y", 0.0, 1e-4, "m"}, {"com_z", 0.02, 1e-4, "m"}};
  return set;
}

TEST(MovingPayloadExport, ExportsOfAPayloadMovingWithASignalSaySo) {
  for (const std::string model : {"paper+rigid_body+payload(grip)", "paper+rigid_body"}) {
    const auto e = ftid::cell::makePayloadExport(setOf(model), ftid::Mat3::Identity(), ftid::Vec3::Zero());
    const bool moving = model.find("payload(") != std::string::npos;
    for (const std::string& text : {ftid::cell::urScriptFile(e, {}), ftid::cell::ros2BroadcasterYaml(e, {})}) {
      EXPECT_EQ(text.find("NOTE: the model's payload moves with a signal (payload(grip))") != std::string::npos, moving)
          << model << "\n" << text;
    }
  }
}

}  // namespace
