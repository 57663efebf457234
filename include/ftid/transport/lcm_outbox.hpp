#pragma once
// LcmOutbox: the non-real-time publishing side of ftidd (docs/daemon.md).
//
// The loop thread calls tryPush(record) only: it copies a fixed-size CycleRecord into a
// wait-free SPSC queue and signals an eventfd (one non-blocking write, no allocation, no lock).
// A normal-priority publisher thread owned by the outbox pops records, converts them with the
// codec into preallocated buffers and calls LCM's raw publish(channel, buf, len). The same
// thread optionally appends every published event to an LCM log file (lcm-logger format) and
// dispatches incoming command_t messages to a handler. The loop thread never calls LCM.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "ftid/common/records.hpp"
#include "ftid/transport/source_filter.hpp"

namespace lcm {
class LCM;
}  // namespace lcm

namespace ftid_lcm {
class command_t;
class ack_t;
}  // namespace ftid_lcm

namespace ftid::transport {

/// LCM channel names (config `lcm.channels.*`). Channel names are at most 63 characters.
struct Channels {
  std::string cycle = "FTID_CYCLE";      ///< cycle_sample_t every cycle
  std::string wrench = "FTID_WRENCH";    ///< compensated_wrench_t every cycle
  std::string stats = "FTID_STATS";      ///< loop_stats_t about once per second
  std::string command = "FTID_COMMAND";  ///< command_t to ftidd
  std::string ack = "FTID_ACK";          ///< ack_t from ftidd
};

struct OutboxOptions {
  /// LCM provider URL. The default keeps traffic on this host (udpm with ttl=0).
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  Channels channels;
  bool publish_cycle = true;   ///< publish cycle_sample_t (raw data for identification)
  bool publish_wrench = true;  ///< publish compensated_wrench_t
  /// If not empty: write every published event to this LCM log file (lcm-logger format).
  std::string record_path;
  /// Receive (commands) only from these sources (ftid/transport/source_filter.hpp): start()
  /// attaches the filter to the udpm receive socket and throws DriverError if it cannot. Empty
  /// = no filter. Ignored for a shared LCM instance (its owner filters).
  std::vector<Ipv4Net> allowed_sources;
};

/// Called on the publisher thread for each well-formed command_t received on channels.command
/// (malformed ones are dropped and counted before it; an exception it throws is caught and logged).
using CommandHandler = void (*)(const ftid_lcm::command_t& command, void* context);

class LcmOutbox {
 public:
  static constexpr std::size_t kQueueCapacity = 1024;

  /// Creates the LCM instance and opens the record file. Throws DriverError if LCM cannot be
  /// created for the URL (e.g. no multicast route for udpm), ConfigError for an over-long
  /// channel name, Error if the record file cannot be opened.
  explicit LcmOutbox(OutboxOptions options);
  /// Uses an existing LCM instance (options.url is ignored), e.g. one memq:// instance shared
  /// with in-process subscribers in tests. It must outlive the outbox. start() subscribes the
  /// command handler on it and stop() unsubscribes it again, so no other thread may subscribe or
  /// unsubscribe on that instance during start()/stop() (LCM's C++ wrapper is not thread-safe
  /// there).
  LcmOutbox(OutboxOptions options, lcm::LCM* shared_lcm);
  ~LcmOutbox();
  LcmOutbox(const LcmOutbox&) = delete;
  LcmOutbox& operator=(const LcmOutbox&) = delete;

  /// Set before start(): command_t messages are then subscribed to and dispatched.
  void setCommandHandler(CommandHandler handler, void* context);

  /// Starts the publisher thread (non-RT; call from a non-RT thread).
  void start();
  /// Publishes what is still queued, stops the thread, unsubscribes the command handler and
  /// closes the record file. Idempotent.
  void stop();

  /// RT side: queue one cycle for publishing. Never blocks or allocates; false (and counted as
  /// dropped) if the queue is full.
  bool tryPush(const CycleRecord& record) noexcept;

  /// Non-RT, any thread: encode and publish now (and record).
  void publishStats(const LoopStatsRecord& stats);
  void publishAck(const ftid_lcm::ack_t& ack);
  /// Non-RT, any thread: publish already-encoded bytes on a channel (and record). 0 on success.
  int publishRaw(const std::string& channel, const void* data, unsigned size);

  /// Non-RT: waits until everything pushed so far has been published (or the timeout expires).
  bool waitIdle(std::chrono::milliseconds timeout);

  struct Counters {
    std::uint64_t pushed = 0;          ///< records accepted by tryPush
    std::uint64_t dropped = 0;         ///< records refused by tryPush (queue full)
    std::uint64_t published = 0;       ///< messages published successfully (all channels)
    std::uint64_t publish_errors = 0;  ///< publish() returned an error
    std::uint64_t recorded = 0;        ///< events written to the record file
    std::uint64_t commands = 0;        ///< datagrams received on the command channel
    std::uint64_t malformed = 0;       ///< of those, not a well-formed command_t: dropped
  };
  Counters counters() const noexcept;
  const OutboxOptions& options() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ftid::transport
