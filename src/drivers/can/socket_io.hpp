#pragma once
// Frame I/O shared by the SocketCAN and SOCK_SEQPACKET transports (private to drivers_can).
#include <chrono>
#include <string>

#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can::detail {

/// recvmsg() one 16-byte can_frame (MSG_DONTWAIT) and its SCM_TIMESTAMPNS/SCM_TIMESTAMP cmsg.
IoResult receiveFrame(int fd, ReceivedFrame& out, int& err) noexcept;
/// recvmmsg() up to max_frames (<= kMaxBatch) frames with their timestamps.
inline constexpr int kMaxBatch = 64;
int receiveBatch(int fd, ReceivedFrame* out, int max_frames, IoResult& status, int& err) noexcept;
/// send() one can_frame (MSG_DONTWAIT | MSG_NOSIGNAL).
IoResult sendFrame(int fd, const can_frame& frame, int& err) noexcept;
/// poll() for POLLIN; true if readable.
bool pollReadable(int fd, std::chrono::milliseconds timeout);
/// Enables SO_TIMESTAMPNS (throws DriverError naming `what`).
void enableTimestamps(int fd, const std::string& what);
std::string errnoText(int err);

}  // namespace ftid::drivers::can::detail
