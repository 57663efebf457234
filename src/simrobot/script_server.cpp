#include "script_server.hpp"

#include <unistd.h>

#include <algorithm>

namespace ftid::simrobot {

ScriptServer::ScriptServer(Controller& controller, int listen_fd) : controller_(controller), listen_fd_(listen_fd) {}

ScriptServer::~ScriptServer() { closeAll(); }

std::vector<std::string> ScriptServer::takePrograms(std::string* rx) {
  std::vector<std::string> programs;
  for (;;) {
    const auto def = rx->find("def ");
    if (def == std::string::npos) break;
    std::size_t pos = def, end_at = std::string::npos;
    while ((pos = rx->find('\n', pos)) != std::string::npos) {
      ++pos;
      if (rx->compare(pos, 3, "end") == 0 &&
          (pos + 3 == rx->size() || (*rx)[pos + 3] == '\n' || (*rx)[pos + 3] == '\r')) {
        end_at = pos + 3;
        break;
      }
    }
    if (end_at == std::string::npos) break;
    programs.push_back(rx->substr(0, end_at));
    rx->erase(0, std::min(rx->size(), end_at + 1));
  }
  return programs;
}

std::size_t ScriptServer::addPollFds(std::vector<pollfd>* fds) const {
  fds->push_back({listen_fd_, POLLIN, 0});
  for (const auto& c : conns_) fds->push_back({c->fd, POLLIN, 0});
  return conns_.size() + 1;
}

void ScriptServer::onPoll(const pollfd* fds, std::size_t n) {
  if (n == 0) return;
  const std::size_t existing = conns_.size();
  if (fds[0].revents & POLLIN) {
    const int fd = net::acceptConnection(listen_fd_);
    if (fd >= 0) {
      auto c = std::make_unique<net::LineConnection>();
      c->fd = fd;
      conns_.push_back(std::move(c));
    }
  }
  for (std::size_t i = 0; i < existing && i + 1 < n; ++i) {
    const pollfd& p = fds[i + 1];
    net::LineConnection* c = conns_[i].get();
    if (p.fd != c->fd) continue;
    if (p.revents & (POLLIN | POLLHUP | POLLERR)) read(c);
  }
}

void ScriptServer::read(net::LineConnection* c) {
  const bool eof = !net::readAvailable(c->fd, &c->rx);
  if (!c->rx.empty()) controller_.log("script port: " + std::to_string(c->rx.size()) + " bytes buffered");
  for (const std::string& program : takePrograms(&c->rx)) controller_.loadProgram(program);
  if (eof) {
    if (c->rx.find("def ") != std::string::npos) controller_.loadProgram(c->rx);
    c->close = true;
  }
}

void ScriptServer::closeMarked() { net::closeMarked(&conns_); }

void ScriptServer::closeAll() { net::closeAll(&conns_, &listen_fd_); }

}  // namespace ftid::simrobot
