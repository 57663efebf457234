// SocketCAN raw socket transport.
#include "ftid/drivers/can/socketcan.hpp"

#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>

#include "ftid/common/error.hpp"
#include "socket_io.hpp"

namespace ftid::drivers::can {

bool socketCanAvailable(std::string* why) {
  const int s = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (s < 0) {
    const int err = errno;
    if (why != nullptr) {
      *why = "socket(PF_CAN, SOCK_RAW, CAN_RAW) failed: " + detail::errnoText(err);
      if (err == EAFNOSUPPORT) *why += " - this kernel has no AF_CAN (SocketCAN) support";
    }
    return false;
  }
  close(s);
  return true;
}

SocketCanTransport::SocketCanTransport(const SocketCanOptions& options)
    : description_("socketcan:" + options.interface) {
  fd_ = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) {
    const int err = errno;
    throw DriverError(description_ + ": cannot open a CAN_RAW socket: " + detail::errnoText(err) +
                      (err == EAFNOSUPPORT
                           ? " - this kernel has no AF_CAN; use the seqpacket: stand-in endpoint"
                           : ""));
  }
  try {
    unsigned int ifindex = 0;
    if (options.interface != "any") {
      ifindex = if_nametoindex(options.interface.c_str());
      if (ifindex == 0)
        throw DriverError(description_ + ": no such network interface '" + options.interface +
                          "' (bring it up with: ip link set " + options.interface +
                          " up type can bitrate 1000000)");
    }
    if (!options.filters.empty()) {
      if (options.filters.size() > CAN_RAW_FILTER_MAX)
        throw DriverError(description_ + ": too many CAN filters");
      if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, options.filters.data(),
                     static_cast<socklen_t>(options.filters.size() * sizeof(can_filter))) != 0)
        throw DriverError(description_ + ": CAN_RAW_FILTER failed: " + detail::errnoText(errno));
    }
    const can_err_mask_t mask = options.error_mask;
    if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) != 0)
      throw DriverError(description_ + ": CAN_RAW_ERR_FILTER failed: " + detail::errnoText(errno));
    const int own = options.receive_own_messages ? 1 : 0;
    if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &own, sizeof own) != 0)
      throw DriverError(description_ + ": CAN_RAW_RECV_OWN_MSGS failed: " +
                        detail::errnoText(errno));
    if (options.receive_buffer_bytes > 0) {
      const int size = options.receive_buffer_bytes;
      if (setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &size, sizeof size) != 0)
        throw DriverError(description_ + ": SO_RCVBUF failed: " + detail::errnoText(errno));
    }
    detail::enableTimestamps(fd_, description_);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(ifindex);
    if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw DriverError(description_ + ": bind failed: " + detail::errnoText(errno));
  } catch (...) {
    close(fd_);
    fd_ = -1;
    throw;
  }
}

SocketCanTransport::~SocketCanTransport() {
  if (fd_ >= 0) close(fd_);
}

IoResult SocketCanTransport::tryReceive(ReceivedFrame& out) noexcept {
  return detail::receiveFrame(fd_, out, last_errno_);
}

int SocketCanTransport::tryReceiveBatch(ReceivedFrame* out, int max_frames,
                                        IoResult& status) noexcept {
  return detail::receiveBatch(fd_, out, max_frames, status, last_errno_);
}

IoResult SocketCanTransport::trySend(const can_frame& frame) noexcept {
  return detail::sendFrame(fd_, frame, last_errno_);
}

bool SocketCanTransport::waitReadable(std::chrono::milliseconds timeout) {
  return detail::pollReadable(fd_, timeout);
}

}  // namespace ftid::drivers::can
