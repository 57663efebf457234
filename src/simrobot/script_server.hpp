#pragma once
// The simulator's script port (30003): a program text is buffered until `def name():` ... a
// column-0 `end` line (or the end of the connection) and then loaded into the controller.
#include <poll.h>

#include <memory>
#include <string>
#include <vector>

#include "ftid/simrobot/controller.hpp"
#include "net.hpp"

namespace ftid::simrobot {

class ScriptServer {
 public:
  ScriptServer(Controller& controller, int listen_fd);  ///< owns listen_fd
  ~ScriptServer();
  ScriptServer(const ScriptServer&) = delete;
  ScriptServer& operator=(const ScriptServer&) = delete;

  /// Removes every complete program from the front of *buffer and returns them in order
  /// (`def` ... column-0 `end`); an incomplete program stays buffered.
  static std::vector<std::string> takePrograms(std::string* buffer);

  std::size_t addPollFds(std::vector<pollfd>* fds) const;
  void onPoll(const pollfd* fds, std::size_t n);
  void closeMarked();
  void closeAll();

 private:
  void read(net::LineConnection* c);

  Controller& controller_;
  int listen_fd_;
  std::vector<std::unique_ptr<net::LineConnection>> conns_;
};

}  // namespace ftid::simrobot
