// Which extra log columns become candidate signals (src/lab/extra_signals.hpp): constructed
// contexts, milliseconds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "extra_signals.hpp"

namespace ftid::lab::detail {
namespace {

struct Columns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;  ///< one row per sample
  std::vector<SampleContext> ctx;
  void build(int n, const std::function<std::vector<double>(int)>& row) {
    rows.clear();
    for (int i = 0; i < n; ++i) rows.push_back(row(i));
    ctx.assign(static_cast<std::size_t>(n), SampleContext{});
    for (int i = 0; i < n; ++i) {
      ctx[static_cast<std::size_t>(i)].extra = rows[static_cast<std::size_t>(i)].data();
      ctx[static_cast<std::size_t>(i)].extra_names = &names;
    }
  }
};

TEST(ExtraSignals, TakesVaryingFiniteColumnsAndLeavesBookkeepingOut) {
  Columns c;
  c.names = {"host_time", "grip", "pose", "kin_wx", "constant", "with_nan", "contact_fx", "valve", "rx", "q_cmd3"};
  c.build(50, [](int i) {
    return std::vector<double>{1.8e9 + i, 0.02 * i, static_cast<double>(i / 10), 0.1 * i, 3.0, i == 7 ? std::nan("") : 1.0 * i,
                               0.5 * i, std::sin(0.1 * i), 0.01 * i, 0.2 * i};
  });
  const ExtraSignals s = extraSignals(c.ctx);
  EXPECT_EQ(s.names, (std::vector<std::string>{"grip", "valve"}));
  EXPECT_TRUE(s.left_out.empty());
  EXPECT_EQ(extraSignalCandidates(s.names),
            (std::vector<std::string>{"payload(grip)", "poly(grip,1)", "payload(valve)", "poly(valve,1)"}));
  EXPECT_TRUE(isBookkeepingColumn("robot_timestamp"));
  EXPECT_TRUE(isSignalName("grip"));
  EXPECT_TRUE(isSignalName("_valve.2"));
  for (const char* bad : {"", "force (N)", "a+b", "2x", "t", "temp", "q4", "wz"}) EXPECT_FALSE(isSignalName(bad)) << bad;
  EXPECT_FALSE(isBookkeepingColumn("grip"));
}

TEST(ExtraSignals, AColumnWhoseNameCannotBeASignalIsNamedInAWarning) {
  Columns c;
  c.names = {"grip", "force (N)"};
  c.build(20, [](int i) { return std::vector<double>{0.1 * i, 0.2 * i}; });
  const ExtraSignals s = extraSignals(c.ctx);
  EXPECT_EQ(s.names, std::vector<std::string>{"grip"});
  EXPECT_EQ(s.unnamable, std::vector<std::string>{"force (N)"});
  std::vector<std::string> warnings;
  (void)withExtraSignals({}, AnalyzeOptions{}, c.ctx, &warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("'force (N)'"), std::string::npos) << warnings[0];
}

TEST(ExtraSignals, NoExtraColumnsNoSignals) {
  std::vector<SampleContext> ctx(10);
  EXPECT_TRUE(extraSignals(ctx).names.empty());
  EXPECT_TRUE(extraSignals({}).names.empty());
}

TEST(ExtraSignals, TheMenuGrowsOnlyWhenTheUserNamedNoCandidatesAndSaysWhatItLeftOut) {
  Columns c;
  for (int k = 0; k < kMaxExtraSignals + 2; ++k) c.names.push_back("s" + std::to_string(k));
  c.build(20, [&](int i) { return std::vector<double>(c.names.size(), 1.0 * i); });
  AnalyzeOptions o;
  std::vector<std::string> warnings;
  const auto menu = withExtraSignals({"cable", "payload", "poly(t,2)"}, o, c.ctx, &warnings);
  EXPECT_EQ(std::count(menu.begin(), menu.end(), "payload"), 0);  // needs a signal: not a candidate
  EXPECT_EQ(static_cast<int>(menu.size()), 2 + 2 * kMaxExtraSignals);
  EXPECT_NE(std::find(menu.begin(), menu.end(), "payload(s0)"), menu.end());
  EXPECT_EQ(std::find(menu.begin(), menu.end(), "payload(s9)"), menu.end());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("'s8', 's9'"), std::string::npos) << warnings[0];
  o.candidates = {"payload(s9)"};
  warnings.clear();
  EXPECT_EQ(withExtraSignals(o.candidates, o, c.ctx, &warnings), o.candidates);
  EXPECT_TRUE(warnings.empty());
}

}  // namespace
}  // namespace ftid::lab::detail
