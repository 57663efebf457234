#include "socket_util.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "ftid/common/error.hpp"

namespace ftid::drivers::ur::detail {

int connectTcp(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout,
               const char* what) {
  const std::string where = std::string(what) + " " + host + ":" + std::to_string(port);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const int gai = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res);
  if (gai != 0 || res == nullptr) {
    throw DriverError("cannot resolve " + where + ": " + gai_strerror(gai));
  }
  const int fd = socket(res->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    freeaddrinfo(res);
    throw DriverError("socket() for " + where + ": " + std::strerror(errno));
  }
  int rc = ::connect(fd, res->ai_addr, res->ai_addrlen);
  freeaddrinfo(res);
  if (rc != 0 && errno != EINPROGRESS) {
    const int e = errno;
    ::close(fd);
    throw DriverError("cannot connect to " + where + ": " + std::strerror(e));
  }
  if (rc != 0) {
    pollfd p{fd, POLLOUT, 0};
    rc = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (rc <= 0) {
      ::close(fd);
      throw DriverError("cannot connect to " + where + ": timed out after " + std::to_string(timeout.count()) +
                        " ms");
    }
    int err = 0;
    socklen_t len = sizeof err;
    getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
    if (err != 0) {
      ::close(fd);
      throw DriverError("cannot connect to " + where + ": " + std::strerror(err));
    }
  }
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // A half-open link (controller powered off, cable pulled: no FIN, no RST) must end in an error,
  // not in silence: keepalive probes after 1 s without traffic, every 1 s, dead after 3 unanswered;
  // and unacknowledged data is given up after 3 s (TCP_USER_TIMEOUT). recv() then fails with
  // ETIMEDOUT.
  int idle = 1, interval = 1, count = 3;
  unsigned user_timeout_ms = 3000;
  setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &one, sizeof one);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle, sizeof idle);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &interval, sizeof interval);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &count, sizeof count);
  setsockopt(fd, IPPROTO_TCP, TCP_USER_TIMEOUT, &user_timeout_ms, sizeof user_timeout_ms);
  return fd;
}

bool sendAll(int fd, const void* data, std::size_t size, std::chrono::milliseconds timeout, std::string* err) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (size > 0) {
    const ssize_t n = ::send(fd, p, size, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      p += n;
      size -= static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      if (err) *err = std::strerror(errno);
      return false;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      if (err) *err = "send timed out";
      return false;
    }
    pollfd pfd{fd, POLLOUT, 0};
    ::poll(&pfd, 1, static_cast<int>(left.count()));
  }
  return true;
}

bool trySendAll(int fd, const void* data, std::size_t size) noexcept {
  const auto* p = static_cast<const std::uint8_t*>(data);
  for (int attempts = 0; size > 0 && attempts < 3; ) {
    const ssize_t n = ::send(fd, p, size, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      p += n;
      size -= static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return false;
    pollfd pfd{fd, POLLOUT, 0};
    ::poll(&pfd, 1, 1);
    ++attempts;
  }
  return size == 0;
}

int waitReadable(int fd, std::int64_t timeout_ns) noexcept {
  if (timeout_ns < 0) timeout_ns = 0;
  timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000), static_cast<long>(timeout_ns % 1'000'000'000)};
  pollfd p{fd, POLLIN, 0};
  for (;;) {
    const int rc = ::ppoll(&p, 1, &ts, nullptr);
    if (rc < 0 && errno == EINTR) return 0;
    if (rc < 0) return -1;
    if (rc == 0) return 0;
    return 1;
  }
}

void closeFd(int* fd) noexcept {
  if (*fd >= 0) ::close(*fd);
  *fd = -1;
}

}  // namespace ftid::drivers::ur::detail
