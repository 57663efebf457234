#pragma once
// Fakes for the daemon seams: a scripted arm, a settable sensor, a fixed-pose motion model, an
// offset-only compensation and a recording sink. None allocates in the loop-side methods.
#include <array>
#include <atomic>
#include <cstdint>

#include "ftid/daemon/seams.hpp"

namespace ftid::daemon::test {

inline std::int64_t g_fake_now_us = 1'700'000'000'000'000;
inline std::int64_t fakeNowUs() noexcept { return g_fake_now_us; }
/// A fake monotonic clock [us] for tests that step the real-time one (fakeNowUs) apart from it.
inline std::int64_t g_fake_mono_us = 5'000'000'000;
inline std::int64_t fakeMonoUs() noexcept { return g_fake_mono_us; }

class FakeArm : public ArmStateSource {
 public:
  Status next_status = Status::kOk;
  RobotStateRecord state;
  int calls = 0;
  FakeArm() {
    state.valid = true;
    state.robot_time = 100.0;
  }
  Status waitForState(std::chrono::nanoseconds, RobotStateRecord* out) noexcept override {
    ++calls;
    if (next_status != Status::kOk) return next_status;
    state.robot_time += 0.008;
    state.recv_utime = g_fake_now_us;
    *out = state;
    return Status::kOk;
  }
};

/// One settable sample, re-sent every cycle (history and newest alike).
class FakeSensor : public SensorSource {
 public:
  SensorSampleRecord sample;
  bool follow_clock = true;  ///< stamp each read with the current time (a fresh sample)
  /// The host's monotonic clock of recv_mono_us: the cycle's (CycleOptions::mono_now_us).
  std::int64_t (*mono_now_us)() noexcept;
  explicit FakeSensor(std::int64_t (*mono)() noexcept = &fakeNowUs) : mono_now_us(mono) {
    sample.valid = true;
  }
  void drain(std::int64_t now_utime, SensorHistory* history,
             SensorSampleRecord* latest) noexcept override {
    if (follow_clock) {
      sample.recv_utime = now_utime - 300;
      sample.recv_mono_us = mono_now_us() - 300;
    }
    history->push(sample);
    *latest = sample;
  }
};

class FixedMotion : public MotionModel {
 public:
  model::SensorMotion motion;
  model::SensorMotion computeSensorMotion(const JointVector&, const JointVector&,
                                          const JointVector&) const noexcept override {
    return motion;
  }
};

/// modelled = offset (a constant), contact = reading - offset. Counts live instances so that
/// tests can check that replaced objects are freed.
class OffsetCompensation : public Compensation {
 public:
  static inline std::atomic<int> alive{0};
  explicit OffsetCompensation(const Wrench& offset) : offset_(offset) { ++alive; }
  ~OffsetCompensation() override { --alive; }
  double tiltU() const noexcept override { return 0.0; }
  double tiltV() const noexcept override { return 0.0; }
  bool compute(const effects::SampleContext& ctx, Wrench* contact, Wrench* modelled) noexcept override {
    *modelled = offset_;
    *contact = ctx.wrench_S - offset_;
    return true;
  }
  const Wrench& offset() const { return offset_; }

 private:
  Wrench offset_;
};

class RecordingSink : public CycleSink {
 public:
  static constexpr int kCapacity = 4096;
  std::array<CycleRecord, kCapacity> records{};
  int count = 0;
  bool accept = true;
  bool tryPush(const CycleRecord& r) noexcept override {
    if (!accept || count >= kCapacity) return false;
    records[static_cast<std::size_t>(count++)] = r;
    return true;
  }
};

}  // namespace ftid::daemon::test
