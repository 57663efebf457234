#include "socket_io.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "ftid/common/clock.hpp"
#include "ftid/common/error.hpp"

namespace ftid::drivers::can {

int CanTransport::tryReceiveBatch(ReceivedFrame* out, int max_frames, IoResult& status) noexcept {
  int n = 0;
  status = IoResult::kOk;
  while (n < max_frames) {
    const IoResult r = tryReceive(out[n]);
    if (r != IoResult::kOk) {
      status = r;
      break;
    }
    ++n;
  }
  return n;
}

std::int64_t realtimeNowNs() noexcept { return realtimeNs(); }

namespace detail {

namespace {

std::int64_t timestampOf(msghdr& msg) noexcept {
  std::int64_t ts = -1;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec t{};
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      ts = static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
    } else if (c->cmsg_type == SCM_TIMESTAMP) {
      timeval t{};
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      ts = static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_usec * 1000;
    }
  }
  return ts >= 0 ? ts : realtimeNowNs();
}

constexpr std::size_t kControlBytes = CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(timeval));

}  // namespace

int receiveBatch(int fd, ReceivedFrame* out, int max_frames, IoResult& status, int& err) noexcept {
  if (max_frames > kMaxBatch) max_frames = kMaxBatch;
  status = IoResult::kOk;
  if (max_frames <= 0) return 0;
  mmsghdr msgs[kMaxBatch];
  iovec iovs[kMaxBatch];
  alignas(cmsghdr) char control[kMaxBatch][kControlBytes];
  for (int i = 0; i < max_frames; ++i) {
    iovs[i].iov_base = &out[i].frame;
    iovs[i].iov_len = sizeof(can_frame);
    std::memset(&msgs[i], 0, sizeof msgs[i]);
    msgs[i].msg_hdr.msg_iov = &iovs[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
    msgs[i].msg_hdr.msg_control = control[i];
    msgs[i].msg_hdr.msg_controllen = kControlBytes;
  }
  const int got = recvmmsg(fd, msgs, static_cast<unsigned>(max_frames), MSG_DONTWAIT, nullptr);
  if (got < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
      status = IoResult::kWouldBlock;
      return 0;
    }
    err = errno;
    status = (errno == ECONNRESET || errno == ENOTCONN || errno == EPIPE) ? IoResult::kClosed
                                                                          : IoResult::kError;
    return 0;
  }
  for (int i = 0; i < got; ++i) {
    if (msgs[i].msg_len == 0) {  // SOCK_SEQPACKET end of stream
      status = IoResult::kClosed;
      return i;
    }
    if (msgs[i].msg_len != sizeof(can_frame) || (msgs[i].msg_hdr.msg_flags & MSG_TRUNC)) {
      err = EMSGSIZE;
      status = IoResult::kError;
      return i;
    }
    out[i].rx_time_ns = timestampOf(msgs[i].msg_hdr);
  }
  if (got < max_frames) status = IoResult::kWouldBlock;
  return got;
}

IoResult receiveFrame(int fd, ReceivedFrame& out, int& err) noexcept {
  iovec iov{};
  iov.iov_base = &out.frame;
  iov.iov_len = sizeof(can_frame);
  alignas(cmsghdr) char control[kControlBytes];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = recvmsg(fd, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return IoResult::kWouldBlock;
    err = errno;
    if (errno == ECONNRESET || errno == ENOTCONN || errno == EPIPE) return IoResult::kClosed;
    return IoResult::kError;
  }
  if (n == 0) return IoResult::kClosed;  // SOCK_SEQPACKET: orderly shutdown by the peer
  if (static_cast<std::size_t>(n) != sizeof(can_frame) || (msg.msg_flags & MSG_TRUNC)) {
    err = EMSGSIZE;  // not a classic CAN frame (e.g. CAN FD): rejected
    return IoResult::kError;
  }
  out.rx_time_ns = timestampOf(msg);
  return IoResult::kOk;
}

IoResult sendFrame(int fd, const can_frame& frame, int& err) noexcept {
  const ssize_t n = send(fd, &frame, sizeof frame, MSG_DONTWAIT | MSG_NOSIGNAL);
  if (n == static_cast<ssize_t>(sizeof frame)) return IoResult::kOk;
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == EINTR))
    return IoResult::kWouldBlock;
  err = n < 0 ? errno : EMSGSIZE;
  if (n < 0 && (errno == EPIPE || errno == ECONNRESET || errno == ENOTCONN))
    return IoResult::kClosed;
  return IoResult::kError;
}

bool pollReadable(int fd, std::chrono::milliseconds timeout) {
  pollfd p{};
  p.fd = fd;
  p.events = POLLIN;
  const int r = poll(&p, 1, static_cast<int>(timeout.count()));
  return r > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR)) != 0;
}

void enableTimestamps(int fd, const std::string& what) {
  int one = 1;
  if (setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) != 0)
    throw DriverError(what + ": setsockopt(SO_TIMESTAMPNS) failed: " + errnoText(errno));
}

std::string errnoText(int err) {
  char buf[128];
  // GNU strerror_r returns the message pointer.
  const char* m = strerror_r(err, buf, sizeof buf);
  return std::string(m) + " (errno " + std::to_string(err) + ")";
}

}  // namespace detail
}  // namespace ftid::drivers::can
