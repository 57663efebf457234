#include "ftid/drivers/ur/rtde_client.hpp"

#include <sys/socket.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "ftid/common/error.hpp"
#include "socket_util.hpp"

namespace ftid::drivers::ur {

namespace {

constexpr std::size_t kRxCapacity = 256 * 1024;
constexpr std::size_t kTextRing = 16;

enum class Slot : std::uint8_t {
  kSkip, kTimestamp, kActualQ, kActualQd, kTargetQ, kTargetQd, kTargetQdd, kTcpPose, kTcpForce,
  kActualCurrent, kTargetMoment, kJointTemperatures, kRobotMode, kSafetyMode, kRuntimeState,
  kRobotStatusBits, kSafetyStatusBits, kSpeedScaling, kTargetSpeedFraction, kOutInt, kOutDouble,
};

struct SlotInfo {
  Slot slot = Slot::kSkip;
  rtde::DataType type = rtde::DataType::kDouble;
  std::uint8_t index = 0;
};

struct NamedSlot {
  const char* name;
  Slot slot;
  rtde::DataType type;
  std::uint32_t field;
};

constexpr NamedSlot kNamedSlots[] = {
    {"timestamp", Slot::kTimestamp, rtde::DataType::kDouble, kFieldTimestamp},
    {"actual_q", Slot::kActualQ, rtde::DataType::kVector6d, kFieldActualQ},
    {"actual_qd", Slot::kActualQd, rtde::DataType::kVector6d, kFieldActualQd},
    {"target_q", Slot::kTargetQ, rtde::DataType::kVector6d, kFieldTargetQ},
    {"target_qd", Slot::kTargetQd, rtde::DataType::kVector6d, kFieldTargetQd},
    {"target_qdd", Slot::kTargetQdd, rtde::DataType::kVector6d, kFieldTargetQdd},
    {"actual_TCP_pose", Slot::kTcpPose, rtde::DataType::kVector6d, kFieldActualTcpPose},
    {"actual_TCP_force", Slot::kTcpForce, rtde::DataType::kVector6d, kFieldActualTcpForce},
    {"actual_current", Slot::kActualCurrent, rtde::DataType::kVector6d, kFieldActualCurrent},
    {"target_moment", Slot::kTargetMoment, rtde::DataType::kVector6d, kFieldTargetMoment},
    {"joint_temperatures", Slot::kJointTemperatures, rtde::DataType::kVector6d, kFieldJointTemperatures},
    {"robot_mode", Slot::kRobotMode, rtde::DataType::kInt32, kFieldRobotMode},
    {"safety_mode", Slot::kSafetyMode, rtde::DataType::kInt32, kFieldSafetyMode},
    {"runtime_state", Slot::kRuntimeState, rtde::DataType::kUint32, kFieldRuntimeState},
    {"robot_status_bits", Slot::kRobotStatusBits, rtde::DataType::kUint32, kFieldRobotStatusBits},
    {"safety_status_bits", Slot::kSafetyStatusBits, rtde::DataType::kUint32, kFieldSafetyStatusBits},
    {"speed_scaling", Slot::kSpeedScaling, rtde::DataType::kDouble, kFieldSpeedScaling},
    {"target_speed_fraction", Slot::kTargetSpeedFraction, rtde::DataType::kDouble, kFieldTargetSpeedFraction},
};

struct TextEntry {
  char message[160];
  char source[32];
  std::uint8_t level;
};

void readVec6(const std::uint8_t* p, Joint6* v) noexcept {
  for (int i = 0; i < 6; ++i) (*v)[i] = rtde::getDouble(p + 8 * i);
}

void copyClamped(char* dst, std::size_t cap, const std::uint8_t* src, std::size_t n) noexcept {
  const std::size_t m = n < cap - 1 ? n : cap - 1;
  std::memcpy(dst, src, m);
  dst[m] = '\0';
}

}  // namespace

struct RtdeClient::Impl {
  int fd = -1;
  std::string where;
  std::vector<std::uint8_t> rx = std::vector<std::uint8_t>(kRxCapacity);
  std::size_t rx_len = 0;
  std::vector<SlotInfo> slots;
  std::uint32_t present = 0;
  std::uint64_t out_int_present = 0, out_double_present = 0;
  std::size_t expected_payload = 0;  // bytes after the recipe id
  std::uint8_t output_recipe_id = 0;
  bool outputs_configured = false;
  std::array<TextEntry, kTextRing> texts{};
  std::size_t text_head = 0, text_count = 0;

  void storeText(const rtde::PackageView& v, int protocol) noexcept {
    TextEntry& e = texts[text_head];
    text_head = (text_head + 1) % kTextRing;
    if (text_count < kTextRing) ++text_count;
    e.message[0] = e.source[0] = '\0';
    e.level = 3;
    const std::uint8_t* p = v.payload;
    const std::size_t n = v.payload_size;
    if (protocol >= 2) {
      if (n < 1) return;
      const std::size_t ml = p[0];
      if (1 + ml >= n) return;
      copyClamped(e.message, sizeof e.message, p + 1, ml);
      const std::size_t sl = p[1 + ml];
      if (2 + ml + sl >= n) return;
      copyClamped(e.source, sizeof e.source, p + 2 + ml, sl);
      e.level = p[2 + ml + sl];
    } else if (n >= 1) {
      e.level = p[0];
      copyClamped(e.message, sizeof e.message, p + 1, n - 1);
    }
  }

  void decode(const std::uint8_t* p, RtdeStatePackage* s) const noexcept {
    for (const SlotInfo& si : slots) {
      switch (si.slot) {
        case Slot::kSkip: break;
        case Slot::kTimestamp: s->timestamp = rtde::getDouble(p); break;
        case Slot::kActualQ: readVec6(p, &s->actual_q); break;
        case Slot::kActualQd: readVec6(p, &s->actual_qd); break;
        case Slot::kTargetQ: readVec6(p, &s->target_q); break;
        case Slot::kTargetQd: readVec6(p, &s->target_qd); break;
        case Slot::kTargetQdd: readVec6(p, &s->target_qdd); break;
        case Slot::kTcpPose: readVec6(p, &s->actual_TCP_pose); break;
        case Slot::kTcpForce: readVec6(p, &s->actual_TCP_force); break;
        case Slot::kActualCurrent: readVec6(p, &s->actual_current); break;
        case Slot::kTargetMoment: readVec6(p, &s->target_moment); break;
        case Slot::kJointTemperatures: readVec6(p, &s->joint_temperatures); break;
        case Slot::kRobotMode: s->robot_mode = rtde::getI32(p); break;
        case Slot::kSafetyMode: s->safety_mode = rtde::getI32(p); break;
        case Slot::kRuntimeState: s->runtime_state = rtde::getU32(p); break;
        case Slot::kRobotStatusBits: s->robot_status_bits = rtde::getU32(p); break;
        case Slot::kSafetyStatusBits: s->safety_status_bits = rtde::getU32(p); break;
        case Slot::kSpeedScaling: s->speed_scaling = rtde::getDouble(p); break;
        case Slot::kTargetSpeedFraction: s->target_speed_fraction = rtde::getDouble(p); break;
        case Slot::kOutInt: s->output_int_register[si.index] = rtde::getI32(p); break;
        case Slot::kOutDouble: s->output_double_register[si.index] = rtde::getDouble(p); break;
      }
      p += rtde::dataTypeSize(si.type);
    }
    s->present = present;
    s->output_int_present = out_int_present;
    s->output_double_present = out_double_present;
  }
};

// ------------------------------------------------------------------------------------------------
InputPackage::InputPackage(const InputRecipe& recipe) : types_(recipe.types) {
  bytes_.assign(rtde::kHeaderSize + 1 + recipe.payload_size, 0);
  rtde::putU16(bytes_.data(), static_cast<std::uint16_t>(bytes_.size()));
  bytes_[2] = static_cast<std::uint8_t>(rtde::PackageType::kDataPackage);
  bytes_[3] = recipe.id;
  for (std::size_t off : recipe.offsets) offsets_.push_back(rtde::kHeaderSize + 1 + off);
}

bool InputPackage::setInt32(std::size_t field, std::int32_t value) noexcept {
  if (field >= types_.size() || types_[field] != rtde::DataType::kInt32) return false;
  rtde::putI32(&bytes_[offsets_[field]], value);
  return true;
}
bool InputPackage::setUint32(std::size_t field, std::uint32_t value) noexcept {
  if (field >= types_.size() || types_[field] != rtde::DataType::kUint32) return false;
  rtde::putU32(&bytes_[offsets_[field]], value);
  return true;
}
bool InputPackage::setDouble(std::size_t field, double value) noexcept {
  if (field >= types_.size() || types_[field] != rtde::DataType::kDouble) return false;
  rtde::putDouble(&bytes_[offsets_[field]], value);
  return true;
}
bool InputPackage::setBool(std::size_t field, bool value) noexcept {
  if (field >= types_.size() || (types_[field] != rtde::DataType::kBool && types_[field] != rtde::DataType::kUint8)) {
    return false;
  }
  bytes_[offsets_[field]] = value ? 1 : 0;
  return true;
}
bool InputPackage::setVector6d(std::size_t field, const Joint6& value) noexcept {
  if (field >= types_.size() || types_[field] != rtde::DataType::kVector6d) return false;
  for (int i = 0; i < 6; ++i) rtde::putDouble(&bytes_[offsets_[field] + 8 * static_cast<std::size_t>(i)], value[i]);
  return true;
}

// ------------------------------------------------------------------------------------------------
RtdeClient::RtdeClient() : impl_(std::make_unique<Impl>()) {}
RtdeClient::~RtdeClient() { disconnect(); }

void RtdeClient::connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout) {
  disconnect();
  impl_->fd = detail::connectTcp(host, port, timeout, "RTDE");
  impl_->where = host + ":" + std::to_string(port);
  impl_->rx_len = 0;
  protocol_version_ = 1;
  streaming_ = false;
  impl_->outputs_configured = false;
}

bool RtdeClient::isConnected() const noexcept { return impl_->fd >= 0; }

void RtdeClient::disconnect() noexcept {
  if (impl_->fd >= 0 && streaming_) {
    const auto pkg = std::array<std::uint8_t, 3>{0x00, 0x03, 0x50};
    detail::trySendAll(impl_->fd, pkg.data(), pkg.size());
  }
  detail::closeFd(&impl_->fd);
  streaming_ = false;
}

namespace {

/// Sends a setup request and waits for the reply of the same type; skips 'U', stores 'M'.
std::vector<std::uint8_t> roundTrip(int fd, const std::string& where, std::vector<std::uint8_t>* rx,
                                    std::size_t* rx_len, const std::vector<std::uint8_t>& request,
                                    rtde::PackageType expected) {
  if (fd < 0) throw DriverError("RTDE: not connected");
  std::string err;
  if (!detail::sendAll(fd, request.data(), request.size(), std::chrono::milliseconds(2000), &err)) {
    throw DriverError("RTDE " + where + ": send failed: " + err);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(2500);
  for (;;) {
    rtde::PackageView view;
    const long n = rtde::findPackage(rx->data(), *rx_len, &view);
    if (n < 0) throw DriverError("RTDE " + where + ": malformed package header");
    if (n > 0) {
      std::vector<std::uint8_t> pkg(rx->begin(), rx->begin() + n);
      std::memmove(rx->data(), rx->data() + n, *rx_len - static_cast<std::size_t>(n));
      *rx_len -= static_cast<std::size_t>(n);
      if (static_cast<rtde::PackageType>(pkg[2]) == expected) return pkg;
      continue;  // 'U' from a previous stream or 'M': not the reply
    }
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      throw DriverError("RTDE " + where + ": no reply to '" + std::string(1, static_cast<char>(expected)) +
                        "' within 2.5 s");
    }
    const int r = detail::waitReadable(fd, left.count());
    if (r < 0) throw DriverError("RTDE " + where + ": poll failed");
    if (r == 0) continue;
    if (*rx_len == rx->size()) throw DriverError("RTDE " + where + ": receive buffer overflow");
    const ssize_t got = ::recv(fd, rx->data() + *rx_len, rx->size() - *rx_len, MSG_DONTWAIT);
    if (got == 0) throw DriverError("RTDE " + where + ": connection closed by the controller");
    if (got < 0 && errno != EAGAIN && errno != EINTR) {
      throw DriverError("RTDE " + where + ": recv failed: " + std::strerror(errno));
    }
    if (got > 0) *rx_len += static_cast<std::size_t>(got);
  }
}

rtde::PackageView viewOf(const std::vector<std::uint8_t>& pkg) {
  rtde::PackageView v;
  rtde::findPackage(pkg.data(), pkg.size(), &v);
  return v;
}

}  // namespace

bool RtdeClient::negotiateProtocolVersion(std::uint16_t version) {
  const auto reply = roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len,
                               rtde::encodeRequestProtocolVersion(version),
                               rtde::PackageType::kRequestProtocolVersion);
  const auto v = viewOf(reply);
  const bool accepted = v.payload_size >= 1 && v.payload[0] == 1;
  if (accepted) protocol_version_ = version;
  return accepted;
}

rtde::ControllerVersion RtdeClient::controllerVersion() {
  const auto reply = roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len, rtde::encodeGetUrcontrolVersion(),
                               rtde::PackageType::kGetUrcontrolVersion);
  const auto v = viewOf(reply);
  if (v.payload_size != 16) {
    throw DriverError("RTDE " + impl_->where + ": controller version reply has " + std::to_string(v.payload_size) +
                      " bytes (expected 16)");
  }
  rtde::ControllerVersion cv;
  cv.major = rtde::getU32(v.payload);
  cv.minor = rtde::getU32(v.payload + 4);
  cv.bugfix = rtde::getU32(v.payload + 8);
  cv.build = rtde::getU32(v.payload + 12);
  return cv;
}

std::vector<std::string> RtdeClient::setupOutputs(double frequency_hz, const std::vector<std::string>& names) {
  if (streaming_) throw DriverError("RTDE: setupOutputs while streaming (pause first)");
  const auto reply = roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len,
                               rtde::encodeSetupOutputs(frequency_hz, names, protocol_version_),
                               rtde::PackageType::kSetupOutputs);
  const rtde::SetupReply r = rtde::decodeSetupReply(viewOf(reply), protocol_version_);
  if (r.types.size() != names.size()) {
    throw DriverError("RTDE " + impl_->where + ": output setup reply lists " + std::to_string(r.types.size()) +
                      " types for " + std::to_string(names.size()) + " variables");
  }
  std::string missing;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (r.types[i] == "NOT_FOUND") missing += (missing.empty() ? "" : ", ") + names[i];
  }
  if (!missing.empty()) {
    throw DriverError("RTDE " + impl_->where + ": the controller does not know these output variables: " + missing);
  }
  std::vector<SlotInfo> slots;
  std::uint32_t present = 0;
  std::uint64_t ip = 0, dp = 0;
  std::size_t total = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    SlotInfo si;
    if (!rtde::parseDataType(r.types[i], &si.type) || rtde::dataTypeSize(si.type) == 0) {
      throw DriverError("RTDE " + impl_->where + ": unknown type '" + r.types[i] + "' for " + names[i]);
    }
    total += rtde::dataTypeSize(si.type);
    for (const NamedSlot& ns : kNamedSlots) {
      if (names[i] == ns.name) {
        if (si.type != ns.type) {
          throw DriverError("RTDE " + impl_->where + ": " + names[i] + " has type " + r.types[i] + ", expected " +
                            rtde::dataTypeName(ns.type));
        }
        si.slot = ns.slot;
        present |= ns.field;
      }
    }
    auto regIndex = [&](const char* prefix, int* idx) {
      const std::string p(prefix);
      if (names[i].rfind(p, 0) != 0) return false;
      try {
        *idx = std::stoi(names[i].substr(p.size()));
      } catch (...) {
        return false;
      }
      return *idx >= 0 && *idx < kNumRegisters;
    };
    int idx = 0;
    if (regIndex("output_int_register_", &idx) && si.type == rtde::DataType::kInt32) {
      si.slot = Slot::kOutInt;
      si.index = static_cast<std::uint8_t>(idx);
      ip |= 1ull << idx;
      present |= kFieldOutputIntRegisters;
    } else if (regIndex("output_double_register_", &idx) && si.type == rtde::DataType::kDouble) {
      si.slot = Slot::kOutDouble;
      si.index = static_cast<std::uint8_t>(idx);
      dp |= 1ull << idx;
      present |= kFieldOutputDoubleRegisters;
    }
    slots.push_back(si);
  }
  impl_->slots = std::move(slots);
  impl_->present = present;
  impl_->out_int_present = ip;
  impl_->out_double_present = dp;
  impl_->expected_payload = total;
  impl_->output_recipe_id = r.recipe_id;
  impl_->outputs_configured = true;
  return r.types;
}

InputRecipe RtdeClient::setupInputs(const std::vector<std::string>& names) {
  const auto reply = roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len, rtde::encodeSetupInputs(names),
                               rtde::PackageType::kSetupInputs);
  const rtde::SetupReply r = rtde::decodeSetupReply(viewOf(reply), protocol_version_);
  std::string bad;
  for (std::size_t i = 0; i < names.size() && i < r.types.size(); ++i) {
    if (r.types[i] == "NOT_FOUND" || r.types[i] == "IN_USE") {
      bad += (bad.empty() ? "" : ", ") + names[i] + " (" + r.types[i] + ")";
    }
  }
  if (r.recipe_id == 0 || r.types.size() != names.size() || !bad.empty()) {
    throw DriverError("RTDE " + impl_->where + ": input recipe refused" +
                      (bad.empty() ? std::string() : ": " + bad) +
                      (bad.find("IN_USE") != std::string::npos
                           ? " (another RTDE client or a fieldbus adapter owns these registers; try "
                             "register offset 24)"
                           : ""));
  }
  InputRecipe recipe;
  recipe.id = r.recipe_id;
  recipe.names = names;
  for (const auto& t : r.types) {
    rtde::DataType dt;
    if (!rtde::parseDataType(t, &dt) || rtde::dataTypeSize(dt) == 0) {
      throw DriverError("RTDE " + impl_->where + ": unknown input type '" + t + "'");
    }
    recipe.types.push_back(dt);
    recipe.offsets.push_back(recipe.payload_size);
    recipe.payload_size += rtde::dataTypeSize(dt);
  }
  return recipe;
}

void RtdeClient::start() {
  if (!impl_->outputs_configured) throw DriverError("RTDE: start() before setupOutputs()");
  const auto reply =
      roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len, rtde::encodeStart(), rtde::PackageType::kStart);
  const auto v = viewOf(reply);
  if (v.payload_size < 1 || v.payload[0] != 1) throw DriverError("RTDE " + impl_->where + ": start refused");
  streaming_ = true;
}

void RtdeClient::pause() {
  const auto reply =
      roundTrip(impl_->fd, impl_->where, &impl_->rx, &impl_->rx_len, rtde::encodePause(), rtde::PackageType::kPause);
  const auto v = viewOf(reply);
  if (v.payload_size < 1 || v.payload[0] != 1) throw DriverError("RTDE " + impl_->where + ": pause refused");
  streaming_ = false;
}

void RtdeClient::sendTextMessage(const std::string& message, const std::string& source, std::uint8_t level) {
  const auto pkg = rtde::encodeTextMessage(message, source, level);
  std::string err;
  if (!detail::sendAll(impl_->fd, pkg.data(), pkg.size(), std::chrono::milliseconds(1000), &err)) {
    throw DriverError("RTDE " + impl_->where + ": text message send failed: " + err);
  }
}

Status RtdeClient::tryReceiveState(std::chrono::nanoseconds timeout,
                                   RtdeStatePackage* out) noexcept {
  Impl& im = *impl_;
  if (im.fd < 0) {
    last_error_ = "not connected";
    return Status::kFault;
  }
  timespec now_ts{};
  clock_gettime(CLOCK_MONOTONIC, &now_ts);
  const std::int64_t start_ns = static_cast<std::int64_t>(now_ts.tv_sec) * 1'000'000'000 + now_ts.tv_nsec;
  const std::int64_t deadline = start_ns + timeout.count();
  bool first = true;
  for (;;) {
    // 1. Pull everything the socket has (non-blocking) so the newest package wins.
    for (;;) {
      if (im.rx_len == im.rx.size()) break;
      const ssize_t got = ::recv(im.fd, im.rx.data() + im.rx_len, im.rx.size() - im.rx_len, MSG_DONTWAIT);
      if (got > 0) {
        im.rx_len += static_cast<std::size_t>(got);
        continue;
      }
      if (got == 0) {
        last_error_ = "connection closed by the controller";
        return Status::kFault;
      }
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        last_error_ = errno == ETIMEDOUT
                          ? "no answer from the controller: TCP keepalive / user timeout (link down or "
                            "controller powered off)"
                          : (errno == ECONNRESET ? "connection reset by the controller" : "recv failed");
        return Status::kFault;
      }
      break;
    }
    // 2. Parse complete packages; remember the newest data package.
    std::size_t pos = 0, newest = 0;
    std::uint32_t found = 0;
    for (;;) {
      rtde::PackageView v;
      const long n = rtde::findPackage(im.rx.data() + pos, im.rx_len - pos, &v);
      if (n < 0) {
        last_error_ = "malformed RTDE package header";
        return Status::kFault;
      }
      if (n == 0) break;
      if (v.type == rtde::PackageType::kDataPackage) {
        if (v.payload_size != im.expected_payload + 1) {
          last_error_ = "RTDE data package size does not match the output recipe";
          return Status::kFault;
        }
        newest = pos;
        ++found;
      } else if (v.type == rtde::PackageType::kTextMessage) {
        im.storeText(v, protocol_version_);
        ++stats_.text_messages;
      }
      pos += static_cast<std::size_t>(n);
    }
    if (found > 0) {
      clock_gettime(CLOCK_MONOTONIC, &now_ts);
      im.decode(im.rx.data() + newest + rtde::kHeaderSize + 1, out);
      out->host_receive_ns = static_cast<std::int64_t>(now_ts.tv_sec) * 1'000'000'000 + now_ts.tv_nsec;
      out->packages_skipped = found - 1;
      stats_.packages_received += 1;
      stats_.packages_skipped += found - 1;
    }
    if (pos > 0) {
      std::memmove(im.rx.data(), im.rx.data() + pos, im.rx_len - pos);
      im.rx_len -= pos;
    }
    if (found > 0) return Status::kOk;
    if (im.rx_len == im.rx.size()) {
      last_error_ = "RTDE receive buffer overflow";
      return Status::kFault;
    }
    // 3. Wait for more bytes.
    clock_gettime(CLOCK_MONOTONIC, &now_ts);
    const std::int64_t now = static_cast<std::int64_t>(now_ts.tv_sec) * 1'000'000'000 + now_ts.tv_nsec;
    if (now >= deadline && !first) {
      ++stats_.timeouts;
      last_error_ = "timeout waiting for RTDE state";
      return Status::kTimeout;
    }
    first = false;
    const int r = detail::waitReadable(im.fd, deadline - now);
    if (r < 0) {
      last_error_ = "poll failed";
      return Status::kFault;
    }
  }
}

Status RtdeClient::trySendInputs(const InputPackage& package) noexcept {
  if (impl_->fd < 0 || package.size() == 0) {
    last_error_ = "not connected";
    return Status::kFault;
  }
  if (!detail::trySendAll(impl_->fd, package.data(), package.size())) {
    ++stats_.send_failures;
    last_error_ = "RTDE send failed";
    return Status::kFault;
  }
  return Status::kOk;
}

std::vector<rtde::TextMessage> RtdeClient::takeTextMessages() {
  std::vector<rtde::TextMessage> out;
  Impl& im = *impl_;
  const std::size_t start = (im.text_head + kTextRing - im.text_count) % kTextRing;
  for (std::size_t k = 0; k < im.text_count; ++k) {
    const TextEntry& e = im.texts[(start + k) % kTextRing];
    out.push_back({e.message, e.source, e.level});
  }
  im.text_count = 0;
  return out;
}

std::vector<std::string> RtdeClient::defaultOutputNames(int register_offset) {
  std::vector<std::string> n = {"timestamp",          "actual_q",          "actual_qd",     "target_q",
                                "target_qd",          "target_qdd",        "actual_TCP_pose", "robot_mode",
                                "safety_mode",        "runtime_state",     "robot_status_bits",
                                "safety_status_bits", "speed_scaling"};
  for (int i = 0; i < 2; ++i) n.push_back("output_int_register_" + std::to_string(register_offset + i));
  for (int i = 0; i < 2; ++i) n.push_back("output_double_register_" + std::to_string(register_offset + i));
  return n;
}

}  // namespace ftid::drivers::ur
