#pragma once
// Socket helpers shared by the simulator's servers (private to src/simrobot).
#include <cstdint>
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

}  // namespace ftid::simrobot::net
