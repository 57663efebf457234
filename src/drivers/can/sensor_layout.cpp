// DBC -> sensor layout, frame grouping by rolling counter, health rules, sample encoding.
#include "ftid/drivers/can/sensor_layout.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "ftid/common/error.hpp"

namespace ftid::drivers::can {

namespace {

bool isImuField(int f) { return f >= kFieldAccX && f <= kFieldAlphaZ; }
bool isWrenchField(int f) { return f >= kFieldFx && f <= kFieldTz; }

std::uint32_t canIdOf(const DbcMessage& m) {
  return m.extended ? (m.id | CAN_EFF_FLAG) : m.id;
}

std::uint32_t lookupKey(const can_frame& f) {
  return isExtendedFrame(f) ? ((f.can_id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.can_id & CAN_SFF_MASK);
}

// Bits that always make a sample invalid. A counter gap and an error frame alone do not (unless
// the options say so); their refinements, a repeated counter and bus-off, do.
constexpr std::uint32_t kAlwaysInvalid = kHealthStale | kHealthNoData | kHealthOutOfRange |
                                         kHealthStatusError | kHealthCounterRepeat |
                                         kHealthBusOff | kHealthTransportDown;

}  // namespace

SensorLayout SensorLayout::fromDbc(const DbcDatabase& dbc, const SensorSignalNames& names) {
  SensorLayout layout;
  const std::string& src = dbc.source;
  // Which message carries each field.
  std::array<const DbcMessage*, kFieldCount> owner{};
  std::array<const DbcSignal*, kFieldCount> signal{};
  int imu_found = 0;
  std::string imu_missing;
  for (int f = 0; f < kFieldCount; ++f) {
    const std::string& name = names.fields[static_cast<std::size_t>(f)];
    if (name.empty()) {
      if (isWrenchField(f))
        throw ConfigError(src + ": the wrench signal name for field " + std::to_string(f) +
                          " is empty; the six wrench signals are required");
      continue;
    }
    for (const auto& m : dbc.messages) {
      if (const DbcSignal* s = m.findSignal(name)) {
        if (owner[static_cast<std::size_t>(f)] != nullptr)
          throw DataError(src + ":" + std::to_string(s->line) + ": signal '" + name +
                          "' appears in messages '" + owner[static_cast<std::size_t>(f)]->name +
                          "' and '" + m.name + "'; sensor signal names must be unique");
        owner[static_cast<std::size_t>(f)] = &m;
        signal[static_cast<std::size_t>(f)] = s;
      }
    }
    if (owner[static_cast<std::size_t>(f)] == nullptr) {
      if (isWrenchField(f))
        throw DataError(src + ": no signal '" + name + "' in the DBC (required for the wrench)");
      if (isImuField(f)) imu_missing += (imu_missing.empty() ? "" : ", ") + name;
      continue;
    }
    if (isImuField(f)) ++imu_found;
  }
  if (imu_found != 0 && imu_found != 9)
    throw DataError(src + ": the DBC has some IMU signals but not " + imu_missing +
                    " (give all nine or none)");
  layout.has_imu_ = imu_found == 9;
  layout.has_temperature_ = owner[kFieldTemperature] != nullptr;
  layout.has_status_ = owner[kFieldStatus] != nullptr;

  int counter_length = -1;
  for (const auto& m : dbc.messages) {
    std::uint32_t mask = 0;
    for (int f = 0; f < kFieldCount; ++f) {
      if (owner[static_cast<std::size_t>(f)] == &m) mask |= 1u << f;
    }
    if (mask == 0) continue;
    if (layout.message_count_ == kMaxMessages)
      throw DataError(src + ": sensor signals are spread over more than " +
                      std::to_string(kMaxMessages) + " messages");
    const DbcSignal* counter = m.findSignal(names.counter);
    if (counter == nullptr)
      throw DataError(src + ":" + std::to_string(m.line) + ": message '" + m.name +
                      "' carries sensor signals but no rolling counter signal '" + names.counter +
                      "'");
    if (counter->is_signed || counter->length > 31)
      throw DataError(src + ":" + std::to_string(counter->line) + ": rolling counter '" +
                      counter->name + "' of '" + m.name + "' must be unsigned, 1..31 bits");
    if (counter_length >= 0 && counter->length != counter_length)
      throw DataError(src + ":" + std::to_string(counter->line) + ": rolling counter of '" +
                      m.name + "' has " + std::to_string(counter->length) +
                      " bits, other messages " + std::to_string(counter_length));
    counter_length = counter->length;
    Message& out = layout.messages_[static_cast<std::size_t>(layout.message_count_++)];
    out.can_id = canIdOf(m);
    out.dlc = m.dlc;
    out.counter = SignalCodec::fromDbc(*counter);
    out.field_mask = mask;
    for (int f = 0; f < kFieldCount; ++f) {
      if (mask & (1u << f))
        out.fields[static_cast<std::size_t>(f)] =
            SignalCodec::fromDbc(*signal[static_cast<std::size_t>(f)]);
    }
  }
  layout.counter_modulus_ = 1u << counter_length;
  return layout;
}

int SensorLayout::findMessage(std::uint32_t can_id) const noexcept {
  for (int i = 0; i < message_count_; ++i) {
    if (messages_[static_cast<std::size_t>(i)].can_id == can_id) return i;
  }
  return -1;
}

bool SensorLayout::fieldCodec(SensorField field, SignalCodec& out) const noexcept {
  for (int i = 0; i < message_count_; ++i) {
    const Message& m = messages_[static_cast<std::size_t>(i)];
    if (m.field_mask & (1u << field)) {
      out = m.fields[static_cast<std::size_t>(field)];
      return true;
    }
  }
  return false;
}

SampleAssembler::SampleAssembler(const SensorLayout& layout, const SensorHealthOptions& options)
    : layout_(layout), options_(options) {
  if (layout.messageCount() == 0) throw ConfigError("sensor layout has no messages");
  if (options_.max_open_groups < 1 || options_.max_open_groups > static_cast<int>(groups_.size()))
    throw ConfigError("max_open_groups must be 1.." + std::to_string(groups_.size()));
  if (options_.stale_timeout_ns <= 0) throw ConfigError("stale timeout must be positive");
  all_messages_mask_ = (1u << layout.messageCount()) - 1u;
  latest_.has_imu = layout.hasImu();
  latest_.has_temperature = layout.hasTemperature();
  latest_.has_status = layout.hasStatus();
}

SampleAssembler::Group* SampleAssembler::findOrOpenGroup(std::uint32_t counter) noexcept {
  Group* free_slot = nullptr;
  Group* oldest = nullptr;
  int open = 0;
  const auto limit = static_cast<std::size_t>(options_.max_open_groups);
  for (std::size_t i = 0; i < limit; ++i) {
    Group& g = groups_[i];
    if (!g.open) {
      if (free_slot == nullptr) free_slot = &g;
      continue;
    }
    ++open;
    if (g.counter == counter) return &g;
    if (oldest == nullptr || g.age < oldest->age) oldest = &g;
  }
  Group* slot = free_slot;
  if (slot == nullptr) {  // all slots busy: abandon the oldest incomplete group
    ++health_.samples_incomplete;
    slot = oldest;
  }
  slot->open = true;
  slot->counter = counter;
  slot->received_mask = 0;
  slot->age = ++group_age_;
  slot->out_of_range = false;
  return slot;
}

bool SampleAssembler::feed(const ReceivedFrame& rf) noexcept {
  const can_frame& f = rf.frame;
  ++health_.frames_received;
  if (isErrorFrame(f)) {
    ++health_.error_frames;
    health_.last_error_class = f.can_id & CAN_ERR_MASK;
    pending_flags_ |= kHealthErrorFrame;
    if (f.can_id & CAN_ERR_BUSOFF) {
      ++health_.bus_off_events;
      bus_off_ = true;
    }
    return false;
  }
  if (isRemoteFrame(f)) {
    ++health_.frames_ignored;
    return false;
  }
  const int index = layout_.findMessage(lookupKey(f));
  if (index < 0) {
    ++health_.frames_ignored;
    return false;
  }
  const SensorLayout::Message& m = layout_.message(index);
  if (f.len < m.dlc) {
    ++health_.frames_malformed;
    return false;
  }
  const auto counter = static_cast<std::uint32_t>(extractRaw(m.counter, f.data));
  Group* g = findOrOpenGroup(counter);
  const std::uint32_t bit = 1u << index;
  if (g->received_mask & bit) {
    // This message already arrived for this counter: the earlier group never completed (lost
    // frames, then the counter wrapped) or the frame is duplicated. Start the group afresh.
    ++health_.samples_incomplete;
    g->received_mask = 0;
    g->out_of_range = false;
    g->age = ++group_age_;
  }
  for (int fi = 0; fi < kFieldCount; ++fi) {
    if ((m.field_mask & (1u << fi)) == 0) continue;
    const SignalCodec& codec = m.fields[static_cast<std::size_t>(fi)];
    const double v = decodePhysical(codec, f.data);
    if (!inRange(codec, v)) g->out_of_range = true;
    g->values[static_cast<std::size_t>(fi)] = v;
  }
  g->received_mask |= bit;
  g->last_rx_ns = rf.rx_time_ns;
  if (g->received_mask != all_messages_mask_) return false;

  // Complete. Groups opened before this one cannot complete any more (frames of one sender
  // arrive in order), so abandon them.
  for (auto& other : groups_) {
    if (other.open && &other != g && other.age < g->age) {
      other.open = false;
      ++health_.samples_incomplete;
    }
  }
  completeGroup(*g);
  g->open = false;
  return true;
}

void SampleAssembler::completeGroup(Group& g) noexcept {
  const auto& v = g.values;
  SensorSample& s = latest_;
  std::uint32_t flags = 0;
  if (have_sample_) {
    const std::uint32_t mod = layout_.counterModulus();
    const std::uint32_t step = (g.counter + mod - s.counter) % mod;
    if (step == 0) {
      flags |= kHealthCounterRepeat | kHealthCounterGap;  // a repeat is this sample's own flag
      ++health_.counter_repeats;
    } else if (step != 1) {
      // The gap flag accumulates until the next read (a read may skip samples).
      pending_flags_ |= kHealthCounterGap;
      ++health_.counter_gaps;
      health_.samples_lost += step - 1;
    }
  }
  ++health_.samples_complete;
  for (int i = 0; i < 6; ++i) s.wrench_S[i] = v[static_cast<std::size_t>(kFieldFx + i)];
  if (layout_.hasImu()) {
    for (int i = 0; i < 3; ++i) {
      s.acc_S[i] = v[static_cast<std::size_t>(kFieldAccX + i)];
      s.w_S[i] = v[static_cast<std::size_t>(kFieldWx + i)];
      s.alpha_S[i] = v[static_cast<std::size_t>(kFieldAlphaX + i)];
    }
  }
  if (layout_.hasTemperature()) s.temp_degC = v[kFieldTemperature];
  if (layout_.hasStatus()) {
    const double st = v[kFieldStatus];
    s.status_word = st >= 0.0 && st < 4294967296.0 ? static_cast<std::uint32_t>(st) : 0xFFFFFFFFu;
    if (s.status_word & options_.status_fault_mask) {
      flags |= kHealthStatusError;
      ++health_.status_faults;
    }
  }
  if (g.out_of_range) {
    flags |= kHealthOutOfRange;
    ++health_.out_of_range;
  }
  bus_off_ = false;          // a complete sample after bus-off: the bus is back
  transport_down_ = false;
  stale_reported_ = false;
  s.counter = g.counter;
  s.rx_time_ns = g.last_rx_ns;
  s.sequence = health_.samples_complete;
  s.health_flags = flags;  // the flags of this sample's values (a gap is pending, above)
  have_sample_ = true;
}

void SampleAssembler::noteTransportProblem() noexcept {
  ++health_.transport_errors;
  transport_down_ = true;
}

void SampleAssembler::readLatest(SensorSample& out, std::int64_t now_ns) noexcept {
  out = latest_;
  std::uint32_t flags =
      (have_sample_ ? latest_.health_flags : kHealthStale | kHealthNoData) | pending_flags_;
  pending_flags_ = 0;  // gap and error-frame flags are reported by one read
  if (have_sample_ && now_ns - latest_.rx_time_ns > options_.stale_timeout_ns) {
    flags |= kHealthStale;
  }
  if ((flags & kHealthStale) && !stale_reported_ && have_sample_) {
    ++health_.stale_events;
    stale_reported_ = true;
  }
  if (bus_off_) flags |= kHealthBusOff | kHealthErrorFrame;
  if (transport_down_) flags |= kHealthTransportDown;
  std::uint32_t invalid = kAlwaysInvalid;
  if (options_.counter_gap_invalidates) invalid |= kHealthCounterGap;
  if (options_.error_frame_invalidates) invalid |= kHealthErrorFrame;
  out.health_flags = flags;
  out.valid = (flags & invalid) == 0;
  out.fresh = have_sample_ && latest_.sequence != last_read_sequence_;
  last_read_sequence_ = latest_.sequence;
}

int encodeSample(const SensorLayout& layout, const SensorValues& values, std::uint32_t counter,
                 std::array<can_frame, SensorLayout::kMaxMessages>& out, bool* saturated) noexcept {
  std::array<double, kFieldCount> v{};
  for (int i = 0; i < 6; ++i) v[static_cast<std::size_t>(kFieldFx + i)] = values.wrench_S[i];
  for (int i = 0; i < 3; ++i) {
    v[static_cast<std::size_t>(kFieldAccX + i)] = values.acc_S[i];
    v[static_cast<std::size_t>(kFieldWx + i)] = values.w_S[i];
    v[static_cast<std::size_t>(kFieldAlphaX + i)] = values.alpha_S[i];
  }
  v[kFieldTemperature] = values.temp_degC;
  v[kFieldStatus] = static_cast<double>(values.status_word);
  bool sat = false;
  const int n = layout.messageCount();
  for (int i = 0; i < n; ++i) {
    const SensorLayout::Message& m = layout.message(i);
    can_frame& f = out[static_cast<std::size_t>(i)];
    std::memset(&f, 0, sizeof f);
    f.can_id = m.can_id;
    f.len = static_cast<std::uint8_t>(m.dlc);
    insertRaw(m.counter, counter % layout.counterModulus(), f.data);
    for (int fi = 0; fi < kFieldCount; ++fi) {
      if ((m.field_mask & (1u << fi)) == 0) continue;
      if (!encodePhysical(m.fields[static_cast<std::size_t>(fi)], v[static_cast<std::size_t>(fi)],
                          f.data))
        sat = true;
    }
  }
  if (saturated != nullptr) *saturated = sat;
  return n;
}

std::array<double, 6> ratedWrenchRange(const DbcDatabase& dbc, const SensorSignalNames& names) {
  std::array<double, 6> range{};
  for (int a = 0; a < 6; ++a) {
    const std::string& name = names.fields[static_cast<std::size_t>(a)];
    const DbcSignal* found = nullptr;
    for (const auto& m : dbc.messages) {
      if (const DbcSignal* s = m.findSignal(name)) found = s;
    }
    if (found == nullptr) throw DataError(dbc.source + ": no signal '" + name + "' (a wrench axis)");
    range[static_cast<std::size_t>(a)] = found->hasRange()
                                             ? std::min(std::abs(found->minimum), std::abs(found->maximum))
                                             : std::numeric_limits<double>::infinity();
  }
  return range;
}

}  // namespace ftid::drivers::can
