// CDR decoders of sensor_msgs/JointState and geometry_msgs/WrenchStamped (include/ftid/logio/cdr.hpp).
#include "ftid/logio/cdr.hpp"

#include <algorithm>
#include <cstring>

#include "ftid/common/error.hpp"

namespace ftid::logio {

namespace {

/// A bounded reader over one serialized message.
class CdrReader {
 public:
  CdrReader(const std::uint8_t* data, std::size_t size, const char* type) : data_(data), size_(size), type_(type) {
    if (data == nullptr || size < 4) fail("encapsulation header", "message shorter than its 4-byte header");
    if (size > kMaxCdrMessageBytes) fail("encapsulation header", "message larger than 1 MiB");
    if (data[0] != 0x00 || (data[1] != 0x00 && data[1] != 0x01)) {
      fail("encapsulation header", "not plain CDR (expected 00 00 or 00 01, found " + hex(data[0]) + " " + hex(data[1]) + ")");
    }
    little_ = data[1] == 0x01;
    pos_ = 4;
    start_ = 4;
  }

  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw DataError(std::string("CDR ") + type_ + ": " + field + " at byte " + std::to_string(start_) + ": " + problem);
  }

  std::uint32_t u32(const char* field) {
    std::uint32_t v = 0;
    raw(field, &v, 4);
    return v;
  }
  std::int32_t i32(const char* field) { return static_cast<std::int32_t>(u32(field)); }
  double f64(const char* field) {
    std::uint64_t bits = 0;
    raw(field, &bits, 8);
    double v = 0.0;
    std::memcpy(&v, &bits, 8);
    return v;
  }

  std::string str(const char* field) {
    const std::uint32_t n = u32(field);
    if (n == 0) return "";  // some writers send an empty string as length 0
    if (n > kMaxCdrStringBytes) fail(field, "string of " + std::to_string(n) + " bytes (at most " + std::to_string(kMaxCdrStringBytes) + ")");
    if (n > size_ - pos_) fail(field, "string of " + std::to_string(n) + " bytes, only " + std::to_string(size_ - pos_) + " left");
    const auto* p = reinterpret_cast<const char*>(data_ + pos_);
    if (p[n - 1] != '\0') fail(field, "string not terminated by NUL");
    std::string s(p, n - 1);
    if (s.find('\0') != std::string::npos) fail(field, "string with an embedded NUL");
    pos_ += n;
    return s;
  }

  /// A sequence's element count, checked against the bytes left (each element >= min_bytes).
  std::size_t count(const char* field, std::size_t min_bytes, std::size_t max_count) {
    const std::uint32_t n = u32(field);
    if (n > max_count) fail(field, std::to_string(n) + " elements (at most " + std::to_string(max_count) + ")");
    if (static_cast<std::size_t>(n) * min_bytes > size_ - pos_) {
      fail(field, std::to_string(n) + " elements do not fit in the " + std::to_string(size_ - pos_) + " bytes left");
    }
    return n;
  }

  std::vector<double> f64seq(const char* field) {
    const std::size_t n = count(field, 8, kMaxJointNames);
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = f64(field);
    return v;
  }

  void end() {
    start_ = pos_;
    if (size_ - pos_ > 8) fail("end", std::to_string(size_ - pos_) + " bytes left after the message");
  }

 private:
  static std::string hex(std::uint8_t b) {
    const char* d = "0123456789abcdef";
    return {d[b >> 4], d[b & 15]};
  }
  void raw(const char* field, void* out, std::size_t n) {
    const std::size_t rel = pos_ - 4;
    const std::size_t pad = (n - rel % n) % n;
    start_ = pos_ + std::min(pad, size_ - pos_);  // the field's first byte (after alignment)
    if (pad + n > size_ - pos_) fail(field, "message ends early");
    pos_ += pad;
    std::uint8_t b[8];
    std::memcpy(b, data_ + pos_, n);
    const bool host_little = [] {
      const std::uint16_t one = 1;
      std::uint8_t first = 0;
      std::memcpy(&first, &one, 1);
      return first == 1;
    }();
    if (host_little != little_) {
      for (std::size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    }
    std::memcpy(out, b, n);
    pos_ += n;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  const char* type_;
  std::size_t pos_ = 0;
  std::size_t start_ = 0;  ///< first byte of the field being read (errors name it)
  bool little_ = true;
};

}  // namespace

JointStateMsg decodeJointState(const std::uint8_t* data, std::size_t size) {
  CdrReader r(data, size, "sensor_msgs/msg/JointState");
  JointStateMsg m;
  m.stamp_sec = r.i32("header.stamp.sec");
  m.stamp_nanosec = r.u32("header.stamp.nanosec");
  m.frame_id = r.str("header.frame_id");
  const std::size_t n = r.count("name", 4, kMaxJointNames);
  m.name.reserve(n);
  for (std::size_t i = 0; i < n; ++i) m.name.push_back(r.str("name"));
  m.position = r.f64seq("position");
  m.velocity = r.f64seq("velocity");
  m.effort = r.f64seq("effort");
  r.end();
  return m;
}

WrenchStampedMsg decodeWrenchStamped(const std::uint8_t* data, std::size_t size) {
  CdrReader r(data, size, "geometry_msgs/msg/WrenchStamped");
  WrenchStampedMsg m;
  m.stamp_sec = r.i32("header.stamp.sec");
  m.stamp_nanosec = r.u32("header.stamp.nanosec");
  m.frame_id = r.str("header.frame_id");
  static const char* const kFields[6] = {"wrench.force.x",  "wrench.force.y",  "wrench.force.z",
                                         "wrench.torque.x", "wrench.torque.y", "wrench.torque.z"};
  for (int a = 0; a < 6; ++a) m.wrench[a] = r.f64(kFields[a]);
  r.end();
  return m;
}

}  // namespace ftid::logio
