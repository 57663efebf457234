#pragma once
// The SocketCAN stand-in: the same 16-byte `struct can_frame` records over a Unix SOCK_SEQPACKET
// socket (message boundaries kept, one frame per datagram, SO_TIMESTAMPNS receive timestamps).
// The server (the sensor simulator) is the "bus": every frame it sends goes to every connected
// client; frames clients send are received by the server. Works on kernels without AF_CAN.
#include <array>
#include <memory>
#include <string>

#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can {

/// Server side: binds a listening socket at `path` (replacing a stale socket file, creating the
/// parent directory if missing). Up to kMaxClients clients; accept happens inside trySend/
/// tryReceive (non-blocking) or acceptPending().
class SeqpacketCanServer final : public CanTransport {
 public:
  static constexpr int kMaxClients = 16;

  explicit SeqpacketCanServer(std::string path);
  ~SeqpacketCanServer() override;  ///< closes every socket and unlinks the path

  /// Accepts every pending connection; returns the number of connected clients.
  int acceptPending() noexcept;
  int clientCount() const noexcept;
  const std::string& path() const noexcept { return path_; }

  /// Broadcasts to every connected client. kOk if at least one client got the frame (or there are
  /// no clients, like a bus without listeners); clients whose queue is full miss it (counted);
  /// disconnected clients are dropped.
  IoResult trySend(const can_frame& frame) noexcept override;
  IoResult tryReceive(ReceivedFrame& out) noexcept override;
  bool waitReadable(std::chrono::milliseconds timeout) override;
  int fd() const noexcept override { return listen_fd_; }
  int lastErrno() const noexcept override { return last_errno_; }
  const char* describe() const noexcept override { return description_.c_str(); }
  /// Frames a client missed because its receive queue was full.
  std::uint64_t framesDropped() const noexcept { return frames_dropped_; }

 private:
  std::string path_;
  std::string description_;
  int listen_fd_ = -1;
  std::array<int, kMaxClients> clients_{};
  int last_errno_ = 0;
  std::uint64_t frames_dropped_ = 0;
};

/// Client side (used by the daemon and tests): connects to a server's socket path.
class SeqpacketCanClient final : public CanTransport {
 public:
  /// Connects (throws DriverError naming the path if nobody listens). receive_buffer_bytes sets
  /// SO_RCVBUF (0 = default).
  explicit SeqpacketCanClient(std::string path, int receive_buffer_bytes = 0);
  ~SeqpacketCanClient() override;

  IoResult tryReceive(ReceivedFrame& out) noexcept override;
  int tryReceiveBatch(ReceivedFrame* out, int max_frames, IoResult& status) noexcept override;
  IoResult trySend(const can_frame& frame) noexcept override;
  bool waitReadable(std::chrono::milliseconds timeout) override;
  int fd() const noexcept override { return fd_; }
  int lastErrno() const noexcept override { return last_errno_; }
  const char* describe() const noexcept override { return description_.c_str(); }
  /// Non-RT: closes and connects again (after kClosed). Returns false if the server is absent.
  bool reconnect();

 private:
  std::string path_;
  std::string description_;
  int receive_buffer_bytes_ = 0;
  int fd_ = -1;
  int last_errno_ = 0;
};

/// A connected pair (socketpair) for tests: frames written to one end are read from the other.
struct SeqpacketPair {
  std::unique_ptr<CanTransport> a;
  std::unique_ptr<CanTransport> b;
};
SeqpacketPair makeSeqpacketPair();

}  // namespace ftid::drivers::can
