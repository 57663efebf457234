#pragma once
// Socket helpers shared by the simulator's servers (private to src/simrobot).
#include <unistd.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ftid::simrobot::net {

/// A non-blocking listening TCP socket on host:port (0: any free port; the bound port goes to
/// *actual). Throws ConfigError for a host that is not an IPv4 address, DriverError naming
/// `what`, host and port if the port cannot be bound.
int listenOn(const std::string& host, std::uint16_t port, std::uint16_t* actual, const char* what);

/// accept4() a pending connection (non-blocking, TCP_NODELAY); -1 if none.
int acceptConnection(int listen_fd);

/// Sends as much of *tx as the socket takes without blocking; sets *close on a hard error.
void flushBytes(int fd, std::vector<std::uint8_t>* tx, bool* close);
void flushText(int fd, std::string* tx, bool* close);

/// Appends everything readable without blocking to *rx. Returns false at end of stream or on a
/// hard error.
bool readAvailable(int fd, std::vector<std::uint8_t>* rx);
bool readAvailable(int fd, std::string* rx);

/// A text connection (dashboard, script port).
struct LineConnection {
  int fd = -1;
  std::string rx;
  std::string tx;
  bool close = false;
  void flush() { flushText(fd, &tx, &close); }
};

/// Closes and removes every connection marked `close`; `on_close(conn)` runs before the socket is
/// closed (for a log line). Conn has `int fd` and `bool close`.
template <class Conn, class OnClose>
void closeMarked(std::vector<std::unique_ptr<Conn>>* conns, OnClose on_close) {
  for (auto it = conns->begin(); it != conns->end();) {
    if ((*it)->close) {
      on_close(it->get());
      ::close((*it)->fd);
      it = conns->erase(it);
    } else {
      ++it;
    }
  }
}
template <class Conn>
void closeMarked(std::vector<std::unique_ptr<Conn>>* conns) {
  closeMarked(conns, [](Conn*) {});
}

/// Closes every connection and the listening socket (set to -1).
template <class Conn>
void closeAll(std::vector<std::unique_ptr<Conn>>* conns, int* listen_fd) {
  for (auto& c : *conns) ::close(c->fd);
  conns->clear();
  if (*listen_fd >= 0) ::close(*listen_fd);
  *listen_fd = -1;
}

}  // namespace ftid::simrobot::net
