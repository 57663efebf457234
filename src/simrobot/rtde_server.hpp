#pragma once
// The simulator's RTDE server (port 30004; docs/robot.md "RTDE server"): protocol v1/v2, several
// connections, one output recipe per connection with decimation floor(f_ctrl / f_requested),
// input recipes with per-connection ownership. It reads the controller's state for the output
// packages and writes the controller's input registers; nothing else.
#include <poll.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/simrobot/controller.hpp"

namespace ftid::simrobot {

class RtdeServer {
 public:
  /// Takes ownership of the listening socket.
  RtdeServer(Controller& controller, int listen_fd);
  ~RtdeServer();
  RtdeServer(const RtdeServer&) = delete;
  RtdeServer& operator=(const RtdeServer&) = delete;

  /// Appends the listening socket and every connection; returns how many were appended.
  std::size_t addPollFds(std::vector<pollfd>* fds) const;
  /// Handles the events of the `n` entries addPollFds() appended (same order).
  void onPoll(const pollfd* fds, std::size_t n);
  /// After a controller tick: the output packages of every started connection whose decimation
  /// counter fires (dropped or held back as the tick says).
  void publish(const Controller::TickResult& tick);
  /// Closes connections marked for closing (a client gone, an error, disconnectAll()).
  void closeMarked();
  void disconnectAll();  ///< marks every connection for closing
  void closeAll();       ///< closes every connection and the listening socket

  int connectionCount() const noexcept { return static_cast<int>(conns_.size()); }
  std::uint64_t packagesSent() const noexcept { return packages_sent_; }
  std::uint64_t packagesDropped() const noexcept { return packages_dropped_; }

  struct OutField;
  struct InField;
  struct Connection;

 private:
  void accept();
  void read(Connection* c);
  void flush(Connection* c);
  void handlePackage(Connection* c, const drivers::ur::rtde::PackageView& v);
  void reply(Connection* c, drivers::ur::rtde::PackageType type, const std::vector<std::uint8_t>& payload);
  void applyInput(const InField& f, const std::uint8_t* p);
  void appendValue(std::vector<std::uint8_t>* out, const OutField& f) const;
  void forget(const Connection* c);  // frees its input registers, logs (before closeMarked closes it)

  Controller& controller_;
  int listen_fd_;
  std::vector<std::unique_ptr<Connection>> conns_;
  std::map<std::string, int> input_owner_;  // variable -> connection id
  int next_conn_id_ = 1;
  std::uint64_t packages_sent_ = 0, packages_dropped_ = 0;
};

}  // namespace ftid::simrobot
