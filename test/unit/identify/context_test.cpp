// samples::buildContexts and ContextSet: the extra log columns and their names reach every sample (what the
// generic effects read), and copies and moves keep pointing at their own storage.
#include <gtest/gtest.h>

#include "ftid/effects/signal_source.hpp"
#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"

namespace ftid::identify {
namespace {

logio::LogData logWithExtraColumns() {
  sim::CellSimConfig cfg = test::paperConfig(false, 41);
  cfg.duration_s = 1.0;
  logio::LogData log = sim::CellSim(cfg).run();
  log.extra_names = {"humidity", "cycle"};
  log.extra_columns.assign(2, {});
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    log.extra_columns[0].push_back(40.0 + 0.5 * static_cast<double>(i));
    log.extra_columns[1].push_back(static_cast<double>(1000 + i));
  }
  return log;
}

/// Every sample reads its own row and the set's names.
void expectPointsInto(const samples::ContextSet& set, const char* what) {
  const effects::SignalSource humidity = effects::SignalSource::parse("humidity");
  const effects::SignalSource cycle = effects::SignalSource::parse("cycle");
  ASSERT_EQ(set.extra_names.size(), 2u) << what;
  for (std::size_t i = 0; i < set.size(); ++i) {
    const effects::SampleContext& c = set.samples[i];
    ASSERT_EQ(c.extra_names, &set.extra_names) << what << ", sample " << i;
    ASSERT_EQ(c.extra, set.extra_rows.data() + 2 * i) << what << ", sample " << i;
    EXPECT_TRUE(humidity.available(c)) << what;
    EXPECT_DOUBLE_EQ(humidity.read(c), 40.0 + 0.5 * static_cast<double>(i)) << what;
    EXPECT_DOUBLE_EQ(cycle.read(c), static_cast<double>(1000 + i)) << what;
  }
}

TEST(ContextSet, ExtraColumnsAndNamesReachEverySample) {
  const samples::ContextSet set = samples::buildContexts(logWithExtraColumns(), test::ur10());
  ASSERT_GT(set.size(), 100u);
  expectPointsInto(set, "built");
}

TEST(ContextSet, CopiesAndMovesPointAtTheirOwnStorage) {
  const samples::ContextSet original = samples::buildContexts(logWithExtraColumns(), test::ur10());
  samples::ContextSet copy(original);
  expectPointsInto(copy, "copy-constructed");
  samples::ContextSet assigned;
  assigned = original;
  expectPointsInto(assigned, "copy-assigned");
  samples::ContextSet moved(std::move(copy));
  expectPointsInto(moved, "move-constructed");
  samples::ContextSet move_assigned;
  move_assigned = std::move(assigned);
  expectPointsInto(move_assigned, "move-assigned");
  expectPointsInto(original, "original after copies");
}

TEST(ContextSet, NoExtraColumnsMeansNoPointers) {
  sim::CellSimConfig cfg = test::paperConfig(false, 42);
  cfg.duration_s = 0.5;
  const samples::ContextSet set = samples::buildContexts(sim::CellSim(cfg).run(), test::ur10());
  ASSERT_TRUE(set.extra_names.empty());
  for (const auto& c : set.samples) {
    EXPECT_EQ(c.extra, nullptr);
    EXPECT_EQ(c.extra_names, nullptr);
  }
}

}  // namespace
}  // namespace ftid::identify
