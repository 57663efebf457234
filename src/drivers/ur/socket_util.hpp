#pragma once
// Small TCP helpers shared by the UR clients (private to drivers_ur). Sockets are non-blocking;
// blocking behaviour is built from poll() with explicit timeouts.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

namespace ftid::drivers::ur::detail {

/// Connects (TCP_NODELAY, O_NONBLOCK). Throws DriverError "what host:port: reason".
int connectTcp(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout,
               const char* what);
/// Writes all bytes within the timeout. Returns false on error/timeout (errno-style text in *err).
bool sendAll(int fd, const void* data, std::size_t size, std::chrono::milliseconds timeout,
             std::string* err);
/// RT-safe send of a small message: non-blocking, finishes partial writes within ~2 ms.
bool trySendAll(int fd, const void* data, std::size_t size) noexcept;
/// Waits until readable; returns 1 readable, 0 timeout, -1 error.
int waitReadable(int fd, std::int64_t timeout_ns) noexcept;
void closeFd(int* fd) noexcept;

}  // namespace ftid::drivers::ur::detail
