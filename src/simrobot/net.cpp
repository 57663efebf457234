#include "net.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "ftid/common/error.hpp"

namespace ftid::simrobot::net {

int listenOn(const std::string& host, std::uint16_t port, std::uint16_t* actual, const char* what) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw DriverError(std::string("sim-robot: socket(): ") + std::strerror(errno));
  int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    throw ConfigError("sim-robot: host must be an IPv4 address (got '" + host + "')");
  }
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    throw DriverError(std::string("sim-robot: cannot listen for ") + what + " on " + host + ":" +
                      std::to_string(port) + ": " + std::strerror(e));
  }
  listen(fd, 16);
  socklen_t len = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  *actual = ntohs(addr.sin_port);
  return fd;
}

int acceptConnection(int listen_fd) {
  const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd >= 0) {
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  return fd;
}

void flushBytes(int fd, std::vector<std::uint8_t>* tx, bool* close) {
  while (!tx->empty()) {
    const ssize_t n = ::send(fd, tx->data(), tx->size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      tx->erase(tx->begin(), tx->begin() + n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
    *close = true;
    return;
  }
}

void flushText(int fd, std::string* tx, bool* close) {
  while (!tx->empty() && !*close) {
    const ssize_t n = ::send(fd, tx->data(), tx->size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      tx->erase(0, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
    *close = true;
  }
}

namespace {
template <class Buffer>
bool readInto(int fd, Buffer* rx, char* buf, std::size_t size) {
  for (;;) {
    const ssize_t n = ::recv(fd, buf, size, MSG_DONTWAIT);
    if (n > 0) {
      rx->insert(rx->end(), buf, buf + n);
      continue;
    }
    return !(n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR));
  }
}
}  // namespace

bool readAvailable(int fd, std::vector<std::uint8_t>* rx) {
  static thread_local char buf[65536];
  return readInto(fd, rx, buf, sizeof buf);
}

bool readAvailable(int fd, std::string* rx) {
  static thread_local char buf[65536];
  return readInto(fd, rx, buf, sizeof buf);
}

}  // namespace ftid::simrobot::net
