// OutputStage::process (ftidd's output frame and low-pass, called every cycle) does not allocate.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/daemon/output_stage.hpp"

TEST(RtOutputStage, ProcessDoesNotAllocateInAnyFrameWithTheFilter) {
  using ftid::daemon::OutputFrame;
  for (OutputFrame frame : {OutputFrame::kSensor, OutputFrame::kTool, OutputFrame::kBase}) {
    ftid::daemon::OutputStageConfig cfg;
    cfg.frame = frame;
    cfg.p_ST_S = ftid::Vec3(0.01, 0.02, 0.15);
    cfg.lowpass_hz = 10.0;
    cfg.sample_rate_hz = 500.0;
    ftid::daemon::OutputStage stage(cfg);
    ftid::Wrench w;
    w << 1, 2, 3, 0.1, 0.2, 0.3;
    double sum = 0.0;
    std::size_t allocations = 0;
    {
      ftid::test::ScopedAllocationCounter counter;
      for (int i = 0; i < 2000; ++i) {
        w(0) = 0.001 * i;
        sum += stage.process(w, ftid::Mat3::Identity(), i % 500 != 7).sum();
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0u) << ftid::daemon::toString(frame);
    EXPECT_TRUE(std::isfinite(sum));
  }
  // The counter does see allocations (the test can fail).
  {
    ftid::test::ScopedAllocationCounter counter;
    auto* v = new std::vector<double>(100);
    asm volatile("" : : "g"(v) : "memory");  // keep the allocation
    EXPECT_GT(counter.count(), 0u);
    delete v;
  }
}

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
