#pragma once
// Positive controls for the allocation counter, one GoogleTest case per allocation kind. Include
// this in every test/rt_safety file and put FTID_ALLOCATION_COUNTER_CONTROLS(); once at namespace scope:
// the binary then proves that, linked as it is, the counter sees a deliberate allocation through
// every entry point (a zero count in the file's real-time tests means something only if these
// pass). Each rt_safety file is its own executable, so the cases are defined once per binary.
#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "alloc_counter.hpp"

namespace ftid::test {
// Readable parameter names in GoogleTest/CTest output.
inline void PrintTo(AllocKind kind, std::ostream* os) { *os << toString(kind); }
inline void PrintTo(const IndirectAllocation& a, std::ostream* os) { *os << a.name; }
}  // namespace ftid::test

// The counter must report exactly one allocation, through the entry point that was called.
#define FTID_ALLOCATION_COUNTER_CONTROLS()                                                              \
  class AllocationCounterControl : public ::testing::TestWithParam<::ftid::test::AllocKind> {};         \
  class AllocationCounterIndirectControl                                                                \
      : public ::testing::TestWithParam<::ftid::test::IndirectAllocation> {};                           \
  TEST_P(AllocationCounterControl, SeesADeliberateAllocation) {                                         \
    const ::ftid::test::AllocKind kind = GetParam();                                                    \
    ::ftid::test::allocateDeliberately(kind); /* warm-up: lazy libc/libstdc++ set-up, outside */        \
    std::size_t total = 0, of_kind = 0, frees = 0;                                                      \
    {                                                                                                   \
      ::ftid::test::ScopedAllocationCounter counter;                                                    \
      ::ftid::test::allocateDeliberately(kind);                                                         \
      total = counter.count();                                                                          \
      of_kind = counter.count(kind);                                                                    \
      frees = counter.frees();                                                                          \
    }                                                                                                   \
    EXPECT_EQ(of_kind, 1u) << ::ftid::test::toString(kind) << " was not counted by its own hook";      \
    EXPECT_EQ(total, 1u) << ::ftid::test::toString(kind);                                               \
    EXPECT_EQ(frees, 1u) << ::ftid::test::toString(kind) << ": the release was not counted";           \
  }                                                                                                     \
  INSTANTIATE_TEST_SUITE_P(                                                                             \
      AllKinds, AllocationCounterControl, ::testing::ValuesIn(::ftid::test::allAllocKinds()),           \
      [](const ::testing::TestParamInfo<::ftid::test::AllocKind>& param) {                              \
        return std::string(::ftid::test::toString(param.param));                                         \
      });                                                                                               \
  TEST_P(AllocationCounterIndirectControl, SeesTheAllocationByItsEntryPoint) {                          \
    const ::ftid::test::IndirectAllocation a = GetParam();                                              \
    a.run(); /* warm-up */                                                                              \
    std::size_t total = 0, of_kind = 0;                                                                 \
    {                                                                                                   \
      ::ftid::test::ScopedAllocationCounter counter;                                                    \
      a.run();                                                                                          \
      total = counter.count();                                                                          \
      of_kind = counter.count(a.expected_kind);                                                         \
    }                                                                                                   \
    EXPECT_GE(of_kind, 1u) << a.name << " expected through " << ::ftid::test::toString(a.expected_kind); \
    EXPECT_GE(total, of_kind) << a.name;                                                                \
  }                                                                                                     \
  INSTANTIATE_TEST_SUITE_P(                                                                             \
      Indirect, AllocationCounterIndirectControl,                                                       \
      ::testing::ValuesIn(::ftid::test::indirectAllocations()),                                         \
      [](const ::testing::TestParamInfo<::ftid::test::IndirectAllocation>& param) {                     \
        return std::string(param.param.name);                                                             \
      })
