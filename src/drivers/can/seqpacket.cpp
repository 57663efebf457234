// SocketCAN stand-in: struct can_frame over Unix SOCK_SEQPACKET sockets.
#include "ftid/drivers/can/seqpacket.hpp"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "ftid/common/error.hpp"
#include "socket_io.hpp"

namespace ftid::drivers::can {

namespace {

sockaddr_un unixAddress(const std::string& path, const std::string& what) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path)
    throw ConfigError(what + ": socket path must be 1.." + std::to_string(sizeof addr.sun_path - 1) +
                      " characters long");
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  return addr;
}

void setBuffer(int fd, int option, int bytes) {
  if (bytes > 0) setsockopt(fd, SOL_SOCKET, option, &bytes, sizeof bytes);  // best effort
}

/// One end of a connected pair (tests).
class SeqpacketEndpoint final : public CanTransport {
 public:
  explicit SeqpacketEndpoint(int fd) : fd_(fd) {}
  ~SeqpacketEndpoint() override { close(fd_); }
  IoResult tryReceive(ReceivedFrame& out) noexcept override {
    return detail::receiveFrame(fd_, out, last_errno_);
  }
  int tryReceiveBatch(ReceivedFrame* out, int max_frames, IoResult& status) noexcept override {
    return detail::receiveBatch(fd_, out, max_frames, status, last_errno_);
  }
  IoResult trySend(const can_frame& frame) noexcept override {
    return detail::sendFrame(fd_, frame, last_errno_);
  }
  bool waitReadable(std::chrono::milliseconds timeout) override {
    return detail::pollReadable(fd_, timeout);
  }
  int fd() const noexcept override { return fd_; }
  int lastErrno() const noexcept override { return last_errno_; }
  const char* describe() const noexcept override { return "seqpacket:socketpair"; }

 private:
  int fd_;
  int last_errno_ = 0;
};

}  // namespace

// ---------------------------------------------------------------------------------------- server

SeqpacketCanServer::SeqpacketCanServer(std::string path)
    : path_(std::move(path)), description_("seqpacket-server:" + path_) {
  clients_.fill(-1);
  const sockaddr_un addr = unixAddress(path_, description_);
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::exists(parent, ec)) {
    std::filesystem::create_directories(parent, ec);
    if (ec)
      throw DriverError(description_ + ": cannot create directory " + parent.string() + ": " +
                        ec.message());
  }
  struct stat st {};
  if (lstat(path_.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode))
      throw DriverError(description_ + ": " + path_ + " exists and is not a socket");
    // A stale socket from an earlier run: refuse if someone still serves it.
    const int probe = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    const bool alive =
        probe >= 0 && connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    if (probe >= 0) close(probe);
    if (alive) throw DriverError(description_ + ": another process already serves " + path_);
    unlink(path_.c_str());
  }
  listen_fd_ = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0)
    throw DriverError(description_ + ": socket failed: " + detail::errnoText(errno));
  if (bind(listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      listen(listen_fd_, kMaxClients) != 0) {
    const int err = errno;
    close(listen_fd_);
    listen_fd_ = -1;
    throw DriverError(description_ + ": cannot listen on " + path_ + ": " + detail::errnoText(err));
  }
}

SeqpacketCanServer::~SeqpacketCanServer() {
  for (int& c : clients_) {
    if (c >= 0) close(c);
    c = -1;
  }
  if (listen_fd_ >= 0) {
    close(listen_fd_);
    unlink(path_.c_str());
  }
}

int SeqpacketCanServer::acceptPending() noexcept {
  for (;;) {
    const int c = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (c < 0) break;
    int one = 1;
    setsockopt(c, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
    setBuffer(c, SO_SNDBUF, 1 << 20);
    bool placed = false;
    for (int& slot : clients_) {
      if (slot < 0) {
        slot = c;
        placed = true;
        break;
      }
    }
    if (!placed) close(c);  // full: the client sees its connection closed
  }
  return clientCount();
}

int SeqpacketCanServer::clientCount() const noexcept {
  int n = 0;
  for (int c : clients_) n += c >= 0 ? 1 : 0;
  return n;
}

IoResult SeqpacketCanServer::trySend(const can_frame& frame) noexcept {
  acceptPending();
  for (int& c : clients_) {
    if (c < 0) continue;
    int err = 0;
    const IoResult r = detail::sendFrame(c, frame, err);
    if (r == IoResult::kWouldBlock) {
      ++frames_dropped_;
    } else if (r != IoResult::kOk) {
      last_errno_ = err;
      close(c);  // client gone
      c = -1;
    }
  }
  return IoResult::kOk;
}

IoResult SeqpacketCanServer::tryReceive(ReceivedFrame& out) noexcept {
  acceptPending();
  for (int& c : clients_) {
    if (c < 0) continue;
    int err = 0;
    const IoResult r = detail::receiveFrame(c, out, err);
    if (r == IoResult::kOk) return r;
    if (r == IoResult::kClosed || r == IoResult::kError) {
      last_errno_ = err;
      close(c);
      c = -1;
    }
  }
  return IoResult::kWouldBlock;
}

bool SeqpacketCanServer::waitReadable(std::chrono::milliseconds timeout) {
  return detail::pollReadable(listen_fd_, timeout);
}

// ---------------------------------------------------------------------------------------- client

SeqpacketCanClient::SeqpacketCanClient(std::string path, int receive_buffer_bytes)
    : path_(std::move(path)),
      description_("seqpacket:" + path_),
      receive_buffer_bytes_(receive_buffer_bytes) {
  unixAddress(path_, description_);  // validates the length
  if (!reconnect())
    throw DriverError(description_ + ": cannot connect to " + path_ + ": " +
                      detail::errnoText(last_errno_) +
                      " (is `ftid sim-sensor` or the sensor bridge running?)");
}

SeqpacketCanClient::~SeqpacketCanClient() {
  if (fd_ >= 0) close(fd_);
}

bool SeqpacketCanClient::reconnect() {
  if (fd_ >= 0) close(fd_);
  fd_ = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    last_errno_ = errno;
    return false;
  }
  const sockaddr_un addr = unixAddress(path_, description_);
  setBuffer(fd_, SO_RCVBUF, receive_buffer_bytes_);
  if (connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    last_errno_ = errno;
    close(fd_);
    fd_ = -1;
    return false;
  }
  // Non-blocking after connect (a blocking connect to a Unix socket completes immediately).
  int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
  return true;
}

IoResult SeqpacketCanClient::tryReceive(ReceivedFrame& out) noexcept {
  if (fd_ < 0) return IoResult::kClosed;
  return detail::receiveFrame(fd_, out, last_errno_);
}

int SeqpacketCanClient::tryReceiveBatch(ReceivedFrame* out, int max_frames,
                                        IoResult& status) noexcept {
  if (fd_ < 0) {
    status = IoResult::kClosed;
    return 0;
  }
  return detail::receiveBatch(fd_, out, max_frames, status, last_errno_);
}

IoResult SeqpacketCanClient::trySend(const can_frame& frame) noexcept {
  if (fd_ < 0) return IoResult::kClosed;
  return detail::sendFrame(fd_, frame, last_errno_);
}

bool SeqpacketCanClient::waitReadable(std::chrono::milliseconds timeout) {
  return fd_ >= 0 && detail::pollReadable(fd_, timeout);
}

SeqpacketPair makeSeqpacketPair() {
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0)
    throw DriverError("socketpair(AF_UNIX, SOCK_SEQPACKET) failed: " + detail::errnoText(errno));
  for (int fd : sv) detail::enableTimestamps(fd, "socketpair");
  SeqpacketPair p;
  p.a = std::make_unique<SeqpacketEndpoint>(sv[0]);
  p.b = std::make_unique<SeqpacketEndpoint>(sv[1]);
  return p;
}

}  // namespace ftid::drivers::can
