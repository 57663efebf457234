#pragma once
// SocketCAN raw socket transport (AF_CAN / CAN_RAW). Kernels without AF_CAN fail in the
// constructor with a DriverError mentioning EAFNOSUPPORT; use the SOCK_SEQPACKET stand-in there.
#include <string>
#include <vector>

#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can {

struct SocketCanOptions {
  std::string interface = "can0";  ///< "can0", "vcan0"; "any" binds to all CAN interfaces
  /// Receive filters (can_id/can_mask as in CAN_RAW_FILTER). Empty = receive every frame.
  std::vector<can_filter> filters;
  /// Error classes to receive as error frames (CAN_RAW_ERR_FILTER); 0 = none.
  can_err_mask_t error_mask = CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_BUSOFF |
                              CAN_ERR_BUSERROR | CAN_ERR_RESTARTED;
  int receive_buffer_bytes = 0;  ///< SO_RCVBUF (0 = kernel default)
  bool receive_own_messages = false;  ///< CAN_RAW_RECV_OWN_MSGS
};

/// True if this kernel supports AF_CAN raw sockets; otherwise `why` says why (e.g. EAFNOSUPPORT).
bool socketCanAvailable(std::string* why = nullptr);

class SocketCanTransport final : public CanTransport {
 public:
  /// Opens, configures and binds the socket (non-blocking, SO_TIMESTAMPNS). Throws DriverError.
  explicit SocketCanTransport(const SocketCanOptions& options);
  ~SocketCanTransport() override;

  IoResult tryReceive(ReceivedFrame& out) noexcept override;
  int tryReceiveBatch(ReceivedFrame* out, int max_frames, IoResult& status) noexcept override;
  IoResult trySend(const can_frame& frame) noexcept override;
  bool waitReadable(std::chrono::milliseconds timeout) override;
  int fd() const noexcept override { return fd_; }
  int lastErrno() const noexcept override { return last_errno_; }
  const char* describe() const noexcept override { return description_.c_str(); }

 private:
  int fd_ = -1;
  int last_errno_ = 0;
  std::string description_;
};

}  // namespace ftid::drivers::can
