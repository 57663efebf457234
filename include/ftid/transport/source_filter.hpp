#pragma once
// Source-address filtering of received LCM datagrams (docs/operations.md, "Network and commands").
//
// LCM 1.3.1's udpm provider binds its receive socket to 0.0.0.0:PORT and offers no source filter,
// so one unicast datagram from any host reaches every subscriber. ftid attaches a classic BPF
// socket filter (SO_ATTACH_FILTER) to that socket: the kernel drops every IPv4 datagram whose
// source address is not in an allow list before it is queued, so LCM never sees it. The default
// allow list is "this host": 127.0.0.0/8 and every IPv4 address configured on a local interface
// at start-up (Linux drops packets arriving from the network with a local source address unless
// accept_local is set, so these sources cannot be spoofed from another host). Multicast this host
// sends through a route on lo carries source 0.0.0.0; the filter accepts 0.0.0.0 only with a
// multicast destination outside 224.0.0.0/24, which Linux never accepts from the network (it
// drops such datagrams in ip_mc_validate_source), so the limited-broadcast case stays closed.
#include <cstdint>
#include <string>
#include <vector>

namespace lcm {
class LCM;
}  // namespace lcm

namespace ftid::transport {

/// An IPv4 network in host byte order (addr & mask == network).
struct Ipv4Net {
  std::uint32_t addr = 0;
  std::uint32_t mask = 0xFFFFFFFFu;
};

/// "This host": 127.0.0.0/8 plus every local IPv4 interface address (/32), read with getifaddrs.
std::vector<Ipv4Net> localSources();

/// Attaches a socket filter to an AF_INET datagram socket that accepts only datagrams whose IPv4
/// source address lies in one of `allowed`. Throws DriverError with the errno text on failure.
void attachSourceFilter(int fd, const std::vector<Ipv4Net>& allowed);

/// The UDP port of an LCM udpm URL ("udpm://239.255.76.67:7667?ttl=0" -> 7667; no port -> 7667,
/// LCM's default); -1 if the URL is not udpm (memq://, file://: nothing to filter).
int udpmPort(const std::string& lcm_url);

/// Finds this process's AF_INET UDP sockets bound to `port` (LCM's receive socket; LCM does not
/// expose it) and attaches the filter to each. Call after subscribing (LCM opens the receive
/// socket then). Returns the number of sockets filtered.
int filterUdpSocketsOnPort(int port, const std::vector<Ipv4Net>& allowed);

/// For an LCM instance created from `url` with at least one subscription: restricts what it
/// receives to `allowed`. No-op for non-udpm URLs. Throws DriverError if the receive socket cannot
/// be found or filtered (the caller must not run unfiltered when asked to filter).
void restrictLcmSources(lcm::LCM& lcm, const std::string& url, const std::vector<Ipv4Net>& allowed);

}  // namespace ftid::transport
