#pragma once
// A CAN transport only moves frames and receive timestamps; it knows nothing about signals.
// Frames are Linux `struct can_frame` (16 bytes, <linux/can.h>): can_id carries the EFF/RTR/ERR
// flags in bits 31/30/29, len is 0..8, data[8]. Implementations:
//   SocketCanTransport      (socketcan.hpp)  raw AF_CAN socket on can0/vcan0
//   SeqpacketCanServer/Client (seqpacket.hpp) the same bytes over a Unix SOCK_SEQPACKET socket
//   CandumpReplayTransport  (candump.hpp)    frames from a candump -l log file
// Receive/send calls are non-blocking, allocation-free and noexcept (safe in the real-time loop);
// constructors and wait*() calls are set-up/non-RT and may throw ftid::DriverError.
#include <linux/can.h>
#include <linux/can/error.h>

#include <chrono>
#include <cstdint>

namespace ftid::drivers::can {

/// A received frame and its receive time: the kernel's SO_TIMESTAMP(NS) where the transport has
/// one, else the time it was read; nanoseconds on CLOCK_REALTIME (Unix time).
struct ReceivedFrame {
  can_frame frame{};
  std::int64_t rx_time_ns = 0;
};

enum class IoResult : std::uint8_t {
  kOk = 0,       ///< one frame received / sent
  kWouldBlock,   ///< nothing pending (receive) or queue full (send): try again later
  kClosed,       ///< peer gone / end of replay: no more frames will arrive on this transport
  kError,        ///< I/O error (see lastErrno())
};

class CanTransport {
 public:
  virtual ~CanTransport() = default;
  CanTransport() = default;
  CanTransport(const CanTransport&) = delete;
  CanTransport& operator=(const CanTransport&) = delete;

  /// Receives one frame if one is pending. Never blocks.
  virtual IoResult tryReceive(ReceivedFrame& out) noexcept = 0;
  /// Receives up to `max_frames` pending frames (socket transports: one recvmmsg call). Never
  /// blocks. Returns the number received; `status` is kOk or kWouldBlock if the transport is
  /// healthy, kClosed/kError if it stopped because of that. Default: repeated tryReceive().
  virtual int tryReceiveBatch(ReceivedFrame* out, int max_frames, IoResult& status) noexcept;
  /// Sends one frame. Never blocks; kWouldBlock means the frame was dropped (queue full).
  virtual IoResult trySend(const can_frame& frame) noexcept = 0;
  /// Blocks (non-RT) until a frame is pending or the timeout expires; true if one is pending.
  virtual bool waitReadable(std::chrono::milliseconds timeout) = 0;
  /// The file descriptor for poll(), or -1 if the transport has none (replay).
  virtual int fd() const noexcept = 0;
  /// errno of the last kError (0 if none).
  virtual int lastErrno() const noexcept = 0;
  /// Human-readable endpoint, e.g. "socketcan:can0" or "seqpacket:/run/ftid/ftsensor.sock".
  virtual const char* describe() const noexcept = 0;
};

/// CLOCK_REALTIME now [ns] (vDSO, real-time safe).
std::int64_t realtimeNowNs() noexcept;

/// True for a frame with CAN_ERR_FLAG set (a controller/bus error report, not data).
inline bool isErrorFrame(const can_frame& f) noexcept { return (f.can_id & CAN_ERR_FLAG) != 0; }
inline bool isRemoteFrame(const can_frame& f) noexcept { return (f.can_id & CAN_RTR_FLAG) != 0; }
inline bool isExtendedFrame(const can_frame& f) noexcept { return (f.can_id & CAN_EFF_FLAG) != 0; }
/// The identifier without flags (11 or 29 bits).
inline std::uint32_t frameId(const can_frame& f) noexcept {
  return isExtendedFrame(f) ? (f.can_id & CAN_EFF_MASK) : (f.can_id & CAN_SFF_MASK);
}

}  // namespace ftid::drivers::can
