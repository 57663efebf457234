// Fuzz target: RTDE package framing and the set-up/text decoders (ftid::drivers::ur::rtde) on a
// byte stream from a hostile controller, as the client walks its receive buffer.
#include <cstddef>
#include <cstdint>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"

namespace rtde = ftid::drivers::ur::rtde;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::size_t pos = 0;
  while (pos < size) {
    rtde::PackageView v;
    const long n = rtde::findPackage(data + pos, size - pos, &v);
    if (n <= 0) break;
    if (static_cast<std::size_t>(n) > size - pos || v.payload + v.payload_size > data + size) __builtin_trap();
    for (int protocol = 1; protocol <= 2; ++protocol) {
      try {
        switch (v.type) {
          case rtde::PackageType::kSetupOutputs:
          case rtde::PackageType::kSetupInputs: {
            const rtde::SetupReply r = rtde::decodeSetupReply(v, protocol);
            for (const auto& t : r.types) {
              rtde::DataType type{};
              (void)rtde::parseDataType(t, &type);
            }
            break;
          }
          case rtde::PackageType::kTextMessage:
            (void)rtde::decodeTextMessage(v, protocol);
            break;
          default: {
            const std::string names(reinterpret_cast<const char*>(v.payload), v.payload_size);
            for (const auto& name : rtde::splitNames(names)) {
              (void)rtde::variableType(name, rtde::Direction::kOutput);
              (void)rtde::variableType(name, rtde::Direction::kInput);
            }
          }
        }
      } catch (const ftid::Error&) {
        // a clear rejection of a malformed package
      }
    }
    pos += static_cast<std::size_t>(n);
  }
  return 0;
}
