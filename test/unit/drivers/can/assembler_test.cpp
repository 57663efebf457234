// Frame grouping by rolling counter and the health rules, on the default sensor DBC.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"
#include "test_paths.hpp"

namespace ftid::drivers::can {
namespace {

const DbcDatabase& defaultDbc() {
  static const DbcDatabase db = loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc"));
  return db;
}

SensorValues someValues(double k = 1.0) {
  SensorValues v;
  v.wrench_S << 1.25 * k, -2.5 * k, -88.05 * k, 0.123 * k, -0.456 * k, 0.05 * k;
  v.acc_S << 0.5 * k, -1.2 * k, 9.806 * k;
  v.w_S << 0.1 * k, -0.2 * k, 0.3 * k;
  v.alpha_S << 1.5 * k, -2.5 * k, 3.5 * k;
  v.temp_degC = 31.37;
  v.status_word = 0;
  return v;
}

class AssemblerTest : public ::testing::Test {
 protected:
  AssemblerTest() : layout_(SensorLayout::fromDbc(defaultDbc())) {}

  // Encodes a sample and returns its frames with rx times t0, t0+1us, ...
  std::vector<ReceivedFrame> frames(const SensorValues& v, std::uint32_t counter,
                                    std::int64_t t0_ns) {
    std::array<can_frame, SensorLayout::kMaxMessages> f{};
    const int n = encodeSample(layout_, v, counter, f);
    std::vector<ReceivedFrame> out;
    for (int i = 0; i < n; ++i) {
      ReceivedFrame rf;
      rf.frame = f[static_cast<std::size_t>(i)];
      rf.rx_time_ns = t0_ns + i * 1000;
      out.push_back(rf);
    }
    return out;
  }
  int feedAll(SampleAssembler& a, const std::vector<ReceivedFrame>& fs) {
    int completed = 0;
    for (const auto& f : fs) completed += a.feed(f) ? 1 : 0;
    return completed;
  }

  SensorLayout layout_;
};

TEST_F(AssemblerTest, LayoutFromDefaultDbc) {
  EXPECT_EQ(layout_.messageCount(), 6);
  EXPECT_EQ(layout_.counterModulus(), 256u);
  EXPECT_TRUE(layout_.hasImu());
  EXPECT_TRUE(layout_.hasTemperature());
  EXPECT_TRUE(layout_.hasStatus());
  EXPECT_EQ(layout_.findMessage(0x1A0), 0);
  EXPECT_EQ(layout_.findMessage(0x1A0 | CAN_EFF_FLAG), -1);
}

TEST_F(AssemblerTest, CompleteSampleDecodesWithinOneQuantisationStep) {
  SampleAssembler a(layout_);
  const SensorValues v = someValues();
  const auto fs = frames(v, 7, 1'000'000'000);
  // Nothing is presented before the last frame of the group.
  for (std::size_t i = 0; i + 1 < fs.size(); ++i) EXPECT_FALSE(a.feed(fs[i]));
  SensorSample s;
  a.readLatest(s, 1'000'000'000);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.health_flags, kHealthStale | kHealthNoData);  // a refinement comes with its bit
  EXPECT_EQ(statusOf(s), Status::kStale);
  EXPECT_TRUE(a.feed(fs.back()));
  a.readLatest(s, 1'000'010'000);
  ASSERT_TRUE(s.valid) << s.health_flags;
  EXPECT_TRUE(s.fresh);
  EXPECT_EQ(s.counter, 7u);
  EXPECT_EQ(s.sequence, 1u);
  EXPECT_EQ(s.rx_time_ns, fs.back().rx_time_ns);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(s.wrench_S[i], v.wrench_S[i], 0.025 + 1e-9);
  for (int i = 3; i < 6; ++i) EXPECT_NEAR(s.wrench_S[i], v.wrench_S[i], 0.0005 + 1e-9);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(s.acc_S[i], v.acc_S[i], 0.001 + 1e-9);
    EXPECT_NEAR(s.w_S[i], v.w_S[i], 0.00025 + 1e-9);
    EXPECT_NEAR(s.alpha_S[i], v.alpha_S[i], 0.0025 + 1e-9);
  }
  EXPECT_NEAR(s.temp_degC, 31.37, 0.005 + 1e-9);
  EXPECT_EQ(s.status_word, 0u);
  // A second read without new frames: same sample, not fresh, still valid.
  a.readLatest(s, 1'000'020'000);
  EXPECT_TRUE(s.valid);
  EXPECT_FALSE(s.fresh);
}

TEST_F(AssemblerTest, FramesOfOneSampleInAnyOrder) {
  SampleAssembler a(layout_);
  std::mt19937 rng(3);
  for (std::uint32_t c = 0; c < 300; ++c) {
    auto fs = frames(someValues(0.5 + 0.001 * c), c, 1'000'000'000 + c * 1'000'000);
    std::shuffle(fs.begin(), fs.end(), rng);
    EXPECT_EQ(feedAll(a, fs), 1);
  }
  EXPECT_EQ(a.health().samples_complete, 300u);
  EXPECT_EQ(a.health().counter_gaps, 0u);  // 255 -> 0 wraps without a gap
  EXPECT_EQ(a.health().samples_incomplete, 0u);
  EXPECT_EQ(a.latest().counter, 299u % 256u);
}

TEST_F(AssemblerTest, MissingFrameDropsTheSampleAndCountsIt) {
  SampleAssembler a(layout_);
  feedAll(a, frames(someValues(), 1, 1'000'000'000));
  auto second = frames(someValues(2.0), 2, 1'001'000'000);
  second.erase(second.begin() + 3);  // lose IMU_Gyro of sample 2
  EXPECT_EQ(feedAll(a, second), 0);
  EXPECT_EQ(feedAll(a, frames(someValues(), 3, 1'002'000'000)), 1);
  SensorSample s;
  a.readLatest(s, 1'002'010'000);
  EXPECT_EQ(s.counter, 3u);
  EXPECT_EQ(a.health().samples_incomplete, 1u);
  EXPECT_EQ(a.health().counter_gaps, 1u);
  EXPECT_EQ(a.health().samples_lost, 1u);
  EXPECT_EQ(s.health_flags, kHealthCounterGap);  // a gap, not a repeat
  EXPECT_TRUE(s.valid);  // default policy: the data itself is fine
  // The gap flag is reported once.
  a.readLatest(s, 1'002'020'000);
  EXPECT_FALSE(s.health_flags & kHealthCounterGap);
  // The wrench is that of sample 3, never a mix with the incomplete sample 2.
  EXPECT_NEAR(s.wrench_S[2], someValues().wrench_S[2], 0.03);
}

TEST_F(AssemblerTest, GapInvalidatesWhenConfigured) {
  SensorHealthOptions o;
  o.counter_gap_invalidates = true;
  SampleAssembler a(layout_, o);
  feedAll(a, frames(someValues(), 10, 1'000'000'000));
  feedAll(a, frames(someValues(), 15, 1'001'000'000));
  SensorSample s;
  a.readLatest(s, 1'001'010'000);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(statusOf(s), Status::kInvalidInput);
  EXPECT_EQ(a.health().samples_lost, 4u);
}

TEST_F(AssemblerTest, RepeatedCounterIsInvalid) {
  SampleAssembler a(layout_);
  feedAll(a, frames(someValues(), 42, 1'000'000'000));
  feedAll(a, frames(someValues(), 42, 1'001'000'000));
  SensorSample s;
  a.readLatest(s, 1'001'010'000);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.health_flags, kHealthCounterGap | kHealthCounterRepeat);
  EXPECT_EQ(a.health().counter_repeats, 1u);
  EXPECT_EQ(a.health().counter_gaps, 0u);
  a.readLatest(s, 1'001'020'000);  // the repeat is the sample's own flag, not reported once
  EXPECT_EQ(s.health_flags, kHealthCounterGap | kHealthCounterRepeat);
  feedAll(a, frames(someValues(), 43, 1'002'000'000));
  a.readLatest(s, 1'002'010'000);
  EXPECT_TRUE(s.valid);
  EXPECT_EQ(s.health_flags, kHealthOk);
}

TEST_F(AssemblerTest, OutOfRangeValueIsInvalid) {
  SampleAssembler a(layout_);
  SensorValues v = someValues();
  v.wrench_S[0] = 350.0;  // rated Fx range is +-300 N; raw range reaches 1638 N
  feedAll(a, frames(v, 1, 1'000'000'000));
  SensorSample s;
  EXPECT_EQ((a.readLatest(s, 1'000'010'000), statusOf(s)), Status::kInvalidInput);
  EXPECT_TRUE(s.health_flags & kHealthOutOfRange);
  EXPECT_NEAR(s.wrench_S[0], 350.0, 0.03);  // the value is shown, but flagged invalid
  EXPECT_EQ(a.health().out_of_range, 1u);
  v.temp_degC = 130.0;  // beyond [-40|125]
  v.wrench_S[0] = 0.0;
  feedAll(a, frames(v, 2, 1'001'000'000));
  a.readLatest(s, 1'001'010'000);
  EXPECT_FALSE(s.valid);
}

TEST_F(AssemblerTest, StatusFaultBitsInvalidateByMask) {
  SensorValues v = someValues();
  v.status_word = 0x0010;  // tare in progress
  {
    SampleAssembler a(layout_);
    feedAll(a, frames(v, 1, 1'000'000'000));
    SensorSample s;
    a.readLatest(s, 1'000'010'000);
    EXPECT_FALSE(s.valid);
    EXPECT_EQ(s.status_word, 0x0010u);
    EXPECT_TRUE(s.health_flags & kHealthStatusError);
  }
  SensorHealthOptions o;
  o.status_fault_mask = 0x000F;  // tare bit not a fault
  SampleAssembler a(layout_, o);
  feedAll(a, frames(v, 1, 1'000'000'000));
  SensorSample s;
  a.readLatest(s, 1'000'010'000);
  EXPECT_TRUE(s.valid);
}

TEST_F(AssemblerTest, StaleAfterTimeoutAndRecovers) {
  SensorHealthOptions o;
  o.stale_timeout_ns = 5'000'000;
  SampleAssembler a(layout_, o);
  feedAll(a, frames(someValues(), 1, 1'000'000'000));
  const std::int64_t t_rx = a.latest().rx_time_ns;
  SensorSample s;
  a.readLatest(s, t_rx + 5'000'000);
  EXPECT_TRUE(s.valid);
  a.readLatest(s, t_rx + 5'000'001);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(statusOf(s), Status::kStale);
  a.readLatest(s, t_rx + 9'000'000);
  EXPECT_EQ(a.health().stale_events, 1u);  // one episode
  feedAll(a, frames(someValues(), 2, 1'010'000'000));
  a.readLatest(s, 1'010'100'000);
  EXPECT_TRUE(s.valid);
}

TEST_F(AssemblerTest, ErrorFramesAreCountedBusOffInvalidates) {
  SampleAssembler a(layout_);
  feedAll(a, frames(someValues(), 1, 1'000'000'000));
  ReceivedFrame err;
  err.frame.can_id = CAN_ERR_FLAG | CAN_ERR_CRTL;
  err.frame.len = CAN_ERR_DLC;
  err.rx_time_ns = 1'000'100'000;
  EXPECT_FALSE(a.feed(err));
  SensorSample s;
  a.readLatest(s, 1'000'200'000);
  EXPECT_TRUE(s.valid);  // error frame flagged, data still complete
  EXPECT_TRUE(s.health_flags & kHealthErrorFrame);
  EXPECT_EQ(a.health().error_frames, 1u);
  EXPECT_EQ(a.health().last_error_class, static_cast<std::uint32_t>(CAN_ERR_CRTL));
  err.frame.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  a.feed(err);
  a.readLatest(s, 1'000'300'000);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.health_flags, kHealthErrorFrame | kHealthBusOff);
  EXPECT_EQ(statusOf(s), Status::kFault);
  EXPECT_EQ(a.health().bus_off_events, 1u);
  feedAll(a, frames(someValues(), 2, 1'001'000'000));
  a.readLatest(s, 1'001'100'000);
  EXPECT_TRUE(s.valid);
}

TEST_F(AssemblerTest, ForeignShortAndRemoteFramesAreIgnored) {
  SampleAssembler a(layout_);
  ReceivedFrame f;
  f.frame.can_id = 0x123;
  f.frame.len = 8;
  a.feed(f);
  f.frame.can_id = 0x1A0 | CAN_EFF_FLAG;  // same number, extended: a different id
  a.feed(f);
  f.frame.can_id = 0x1A0 | CAN_RTR_FLAG;
  a.feed(f);
  f.frame.can_id = 0x1A0;
  f.frame.len = 4;  // too short for FT_Force
  a.feed(f);
  EXPECT_EQ(a.health().frames_ignored, 3u);
  EXPECT_EQ(a.health().frames_malformed, 1u);
  EXPECT_EQ(a.health().samples_complete, 0u);
}

TEST_F(AssemblerTest, LayoutErrorsNameTheDbc) {
  const DbcDatabase db = parseDbc(
      "BO_ 1 A: 8 S\n SG_ Counter : 0|8@1+ (1,0) [0|0] \"\" X\n"
      " SG_ Fx : 8|16@1- (1,0) [0|0] \"\" X\n SG_ Fy : 24|16@1- (1,0) [0|0] \"\" X\n"
      " SG_ Fz : 40|16@1- (1,0) [0|0] \"\" X\n"
      "BO_ 2 B: 8 S\n SG_ Tx : 8|16@1- (1,0) [0|0] \"\" X\n SG_ Ty : 24|16@1- (1,0) [0|0] \"\" X\n"
      " SG_ Tz : 40|16@1- (1,0) [0|0] \"\" X\n",
      "mini.dbc");
  try {
    SensorLayout::fromDbc(db);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("mini.dbc:6: message 'B'"), std::string::npos)
        << e.what();
  }
  SensorSignalNames names;
  names.fields[kFieldFx] = "Force_X";
  EXPECT_THROW(SensorLayout::fromDbc(defaultDbc(), names), DataError);
}

TEST_F(AssemblerTest, WrenchOnlySensorHasNoImu) {
  const DbcDatabase db = parseDbc(
      "BO_ 1 A: 8 S\n SG_ Counter : 0|4@1+ (1,0) [0|0] \"\" X\n"
      " SG_ Fx : 8|16@1- (0.1,0) [0|0] \"\" X\n SG_ Fy : 24|16@1- (0.1,0) [0|0] \"\" X\n"
      " SG_ Fz : 40|16@1- (0.1,0) [0|0] \"\" X\n"
      "BO_ 2 B: 8 S\n SG_ Counter : 0|4@1+ (1,0) [0|0] \"\" X\n"
      " SG_ Tx : 8|16@1- (0.01,0) [0|0] \"\" X\n SG_ Ty : 24|16@1- (0.01,0) [0|0] \"\" X\n"
      " SG_ Tz : 40|16@1- (0.01,0) [0|0] \"\" X\n",
      "mini.dbc");
  const SensorLayout l = SensorLayout::fromDbc(db);
  EXPECT_FALSE(l.hasImu());
  EXPECT_EQ(l.counterModulus(), 16u);
  SampleAssembler a(l);
  std::array<can_frame, SensorLayout::kMaxMessages> f{};
  ASSERT_EQ(encodeSample(l, someValues(), 17, f), 2);  // 17 mod 16 = 1
  ReceivedFrame rf;
  rf.frame = f[0];
  a.feed(rf);
  rf.frame = f[1];
  EXPECT_TRUE(a.feed(rf));
  EXPECT_EQ(a.latest().counter, 1u);
  EXPECT_FALSE(a.latest().has_imu);
  EXPECT_TRUE(std::isnan(a.latest().temp_degC));
}

}  // namespace
}  // namespace ftid::drivers::can
