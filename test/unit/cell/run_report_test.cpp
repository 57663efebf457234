// The text of an identification run (src/cell/run_report.hpp): the axes the residual table marks
// "above noise" and the axes the run's closing sentence names are the same, so the sentence never
// says "the model explains the data down to the sensor noise" under a table that marks an axis
// (a disturbed demo run printed both, 6-11x the floor on five axes).
#include <gtest/gtest.h>

#include <string>

#include "ftid/identify/noise.hpp"
#include "run_report.hpp"

namespace ftid::cell::internal {
namespace {

int marks(const std::string& table) {
  int n = 0;
  for (std::size_t at = table.find("<- above noise"); at != std::string::npos;
       at = table.find("<- above noise", at + 1)) {
    ++n;
  }
  return n;
}

TEST(RunReport, TheSentenceNamesTheAxesTheTableMarks) {
  const Vec6 noise = (Vec6() << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01).finished();
  const Vec6 raw = Vec6::Constant(5.0);
  Vec6 heldout = noise;  // at the floor: nothing marked, nothing named
  EXPECT_EQ(marks(axisTable(heldout, noise, raw)), 0);
  EXPECT_EQ(axesAboveFloor(heldout, noise), "");
  heldout(0) = 6.04 * noise(0);
  heldout(5) = 1.01 * identify::kAboveFloorMark * noise(5);
  EXPECT_EQ(marks(axisTable(heldout, noise, raw)), 2);
  const std::string named = axesAboveFloor(heldout, noise);
  EXPECT_EQ(named.rfind("fx 6.04x, tz ", 0), 0u) << named;
  heldout(5) = 0.99 * identify::kAboveFloorMark * noise(5);  // just below the mark: neither
  EXPECT_EQ(marks(axisTable(heldout, noise, raw)), 1);
  EXPECT_EQ(axesAboveFloor(heldout, noise), "fx 6.04x");
}

}  // namespace
}  // namespace ftid::cell::internal
