#include "ftid/transport/source_filter.hpp"

#include <arpa/inet.h>
#include <dirent.h>
#include <ifaddrs.h>
#include <linux/filter.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"

namespace ftid::transport {

std::vector<Ipv4Net> localSources() {
  std::vector<Ipv4Net> out;
  out.push_back({0x7F000000u, 0xFF000000u});
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) == 0) {
    for (ifaddrs* a = list; a != nullptr; a = a->ifa_next) {
      if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
      const auto* sin = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
      out.push_back({ntohl(sin->sin_addr.s_addr), 0xFFFFFFFFu});
    }
    ::freeifaddrs(list);
  }
  return out;
}

void attachSourceFilter(int fd, const std::vector<Ipv4Net>& allowed) {
  if (allowed.empty() || allowed.size() > 80) {
    throw DriverError("source filter: need 1 to 80 allowed networks, got " + std::to_string(allowed.size()));
  }
  // Classic BPF. A = IPv4 source address (network header + 12), destination at + 16.
  // Multicast that this host sends through a route on lo leaves with source 0.0.0.0 (no address
  // of a suitable scope on lo); Linux drops 0.0.0.0-sourced datagrams from the network except to
  // 224.0.0.0/24 (link-local multicast) and the limited broadcast, so 0.0.0.0 is accepted only for
  // a multicast destination outside 224.0.0.0/24.
  const auto n = allowed.size();
  const std::uint32_t kDrop = static_cast<std::uint32_t>(8 + 3 * n);  // index of "ret 0"
  const auto src = static_cast<std::uint32_t>(SKF_NET_OFF + 12);
  const auto dst = static_cast<std::uint32_t>(SKF_NET_OFF + 16);
  auto off = [](std::uint32_t to, std::uint32_t from) { return static_cast<std::uint8_t>(to - from - 1); };
  std::vector<sock_filter> prog;
  prog.push_back(BPF_STMT(BPF_LD | BPF_W | BPF_ABS, src));                      // 0
  prog.push_back(BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, 0, 0, 6));                  // 1: src != 0 -> 8
  prog.push_back(BPF_STMT(BPF_LD | BPF_W | BPF_ABS, dst));                      // 2
  prog.push_back(BPF_STMT(BPF_ALU | BPF_AND | BPF_K, 0xF0000000u));              // 3
  prog.push_back(BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, 0xE0000000u, 0, off(kDrop, 4)));  // 4: not multicast
  prog.push_back(BPF_STMT(BPF_LD | BPF_W | BPF_ABS, dst));                      // 5
  prog.push_back(BPF_STMT(BPF_ALU | BPF_AND | BPF_K, 0xFFFFFF00u));              // 6
  prog.push_back(BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, 0xE0000000u, off(kDrop, 7), off(kDrop + 1, 7)));  // 7
  for (std::size_t i = 0; i < n; ++i) {
    const auto at = static_cast<std::uint32_t>(8 + 3 * i);
    prog.push_back(BPF_STMT(BPF_LD | BPF_W | BPF_ABS, src));
    prog.push_back(BPF_STMT(BPF_ALU | BPF_AND | BPF_K, allowed[i].mask));
    prog.push_back(BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, allowed[i].addr & allowed[i].mask,
                            off(kDrop + 1, at + 2), 0));
  }
  prog.push_back(BPF_STMT(BPF_RET | BPF_K, 0));            // drop
  prog.push_back(BPF_STMT(BPF_RET | BPF_K, 0xFFFFFFFFu));  // accept the whole datagram
  sock_fprog fprog{};
  fprog.len = static_cast<unsigned short>(prog.size());
  fprog.filter = prog.data();
  if (::setsockopt(fd, SOL_SOCKET, SO_ATTACH_FILTER, &fprog, sizeof fprog) != 0) {
    throw DriverError(std::string("source filter: SO_ATTACH_FILTER failed: ") + std::strerror(errno));
  }
}

int udpmPort(const std::string& url) {
  const std::string scheme = "udpm://";
  if (url.compare(0, scheme.size(), scheme) != 0) return -1;
  const std::string rest = url.substr(scheme.size());
  const std::size_t end = rest.find('?');
  const std::string hostport = rest.substr(0, end);
  const std::size_t colon = hostport.rfind(':');
  if (colon == std::string::npos) return 7667;
  const std::string p = hostport.substr(colon + 1);
  char* stop = nullptr;
  const long v = std::strtol(p.c_str(), &stop, 10);
  if (p.empty() || *stop != '\0' || v <= 0 || v > 65535) {
    throw ConfigError("LCM URL '" + url + "': bad port '" + p + "'");
  }
  return static_cast<int>(v);
}

int filterUdpSocketsOnPort(int port, const std::vector<Ipv4Net>& allowed) {
  DIR* dir = ::opendir("/proc/self/fd");
  if (dir == nullptr) throw DriverError(std::string("source filter: /proc/self/fd: ") + std::strerror(errno));
  std::vector<int> fds;
  while (dirent* e = ::readdir(dir)) {
    char* stop = nullptr;
    const long fd = std::strtol(e->d_name, &stop, 10);
    if (*stop == '\0' && e->d_name[0] != '\0' && fd != ::dirfd(dir)) fds.push_back(static_cast<int>(fd));
  }
  ::closedir(dir);
  int filtered = 0;
  for (int fd : fds) {
    int type = 0;
    int domain = 0;
    socklen_t len = sizeof type;
    if (::getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_DGRAM) continue;
    len = sizeof domain;
    if (::getsockopt(fd, SOL_SOCKET, SO_DOMAIN, &domain, &len) != 0 || domain != AF_INET) continue;
    sockaddr_in sin{};
    len = sizeof sin;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&sin), &len) != 0) continue;
    if (ntohs(sin.sin_port) != port) continue;
    attachSourceFilter(fd, allowed);
    ++filtered;
  }
  return filtered;
}

void restrictLcmSources(lcm::LCM& lcm, const std::string& url, const std::vector<Ipv4Net>& allowed) {
  const int port = udpmPort(url);
  if (port < 0) return;
  (void)lcm.getFileno();  // makes LCM open its receive socket if it has not yet
  if (filterUdpSocketsOnPort(port, allowed) == 0) {
    throw DriverError("LCM '" + url + "': could not find the receive socket on UDP port " +
                      std::to_string(port) + " to restrict its sources");
  }
}

}  // namespace ftid::transport
