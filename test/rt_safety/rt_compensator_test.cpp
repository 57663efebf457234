// Compensator::compute is allocation-free (counted by the test allocator) for the paper model,
// including the rejected-input path.
#include <gtest/gtest.h>

#include <limits>

#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/compensate/compensator.hpp"

namespace ftid::compensate {
namespace {

TEST(RtCompensator, ComputeDoesNotAllocate) {
  const auto model = effects::Model::fromName("paper");
  Eigen::VectorXd theta = Eigen::VectorXd::LinSpaced(model.numParams(), 0.1, 1.0);
  Compensator comp(model, theta, 0.01, -0.02);
  effects::SampleContext ctx;
  ctx.R_BS = Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  ctx.wrench_S << 1, 2, 3, 0.1, 0.2, 0.3;
  ctx.a_S = Vec3(0.5, -0.2, 0.1);
  Wrench contact, modelled;
  ASSERT_EQ(comp.compute(ctx, &contact, &modelled), Status::kOk);  // warm-up
  std::size_t allocations = 0;
  double sum = 0.0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 1000; ++i) {
      ctx.t = 0.008 * i;
      ctx.a_S.x() = 0.001 * i;
      if (comp.compute(ctx, &contact, &modelled) != Status::kOk) sum += 1e9;
      sum += contact.sum();
    }
    ctx.wrench_S(0) = std::numeric_limits<double>::quiet_NaN();
    if (comp.compute(ctx, &contact, &modelled) != Status::kInvalidInput) sum += 1e9;
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_LT(std::abs(sum), 1e8);
  // The counter does see allocations (the test can fail).
  {
    ftid::test::ScopedAllocationCounter counter;
    Compensator copy(model, theta, 0.0, 0.0);
    EXPECT_GT(counter.count(), 0u);
  }
}

}  // namespace
}  // namespace ftid::compensate

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
