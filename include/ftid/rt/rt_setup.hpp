#pragma once
// Process and thread real-time set-up (docs/daemon.md, docs/architecture.md).
//  - lockProcessMemory(): mlockall(MCL_CURRENT|MCL_FUTURE) after checking RLIMIT_MEMLOCK, then
//    mallopt(M_TRIM_THRESHOLD, -1) and mallopt(M_MMAP_MAX, 0) so freed memory stays mapped.
//  - configureCurrentThread(): SCHED_FIFO at `priority` and CPU affinity, for the calling (loop)
//    thread only; prefaults `stack_prefault_bytes` of its stack.
//  - DmaLatencyRequest: holds /dev/cpu_dma_latency open with 0 (root only) while alive.
// Without privileges each step reports what failed; `require == false` prints ONE warning per
// process and continues as a normal thread, `require == true` throws RealtimeSetupError.
#include <cstddef>
#include <string>
#include <vector>

namespace ftid::rt {

struct RealtimeConfig {
  bool enable = true;           ///< false: skip everything (plain thread)
  bool require = false;         ///< true: a failure of SCHED_FIFO, mlockall or pinning throws
                                ///< RealtimeSetupError (the DMA latency request never does)
  int priority = 80;            ///< SCHED_FIFO priority of the loop thread (1..99)
  int cpu = -1;                 ///< pin the loop thread to this CPU (-1: no pinning)
  bool lock_memory = true;      ///< mlockall + mallopt
  /// Hold the PM QoS device at 0 us while the loop runs. Best effort even with `require`: it is
  /// power management, not a scheduling guarantee, the device is root-only unless a udev rule
  /// opens it, and a hardened unit (PrivateDevices=yes) hides it; a failure is a warning.
  bool dma_latency = true;
  std::string dma_latency_path = "/dev/cpu_dma_latency";  ///< the PM QoS device (tests use another)
  std::size_t stack_size = 1024 * 1024;          ///< loop thread stack [bytes]
  std::size_t stack_prefault_bytes = 512 * 1024;  ///< touched at thread start
};

/// What was achieved; `problems` lists failures in words (empty = fully real-time).
struct RealtimeReport {
  bool memory_locked = false;
  bool fifo = false;
  bool pinned = false;
  bool dma_latency = false;
  bool realtime_kernel = false;  ///< /sys/kernel/realtime == 1
  std::vector<std::string> problems;
  std::string describe() const;  ///< one line, e.g. "SCHED_FIFO 80, mlockall, cpu 1"
};

/// True if /sys/kernel/realtime reads 1 (PREEMPT_RT).
bool hasRealtimeKernel() noexcept;

/// Locks memory. Appends problems to *report; throws RealtimeSetupError if cfg.require and failed.
void lockProcessMemory(const RealtimeConfig& cfg, RealtimeReport* report);
/// Scheduling + affinity + stack prefault for the calling thread. Same error policy.
void configureCurrentThread(const RealtimeConfig& cfg, RealtimeReport* report);
/// Touches `bytes` of the current stack so later page faults do not happen in the loop.
void prefaultStack(std::size_t bytes) noexcept;
/// Prints the report's problems to stderr once per process ("running without real-time ...").
void warnOnce(const RealtimeReport& report);

/// RAII request of zero CPU DMA latency (keeps the fd open).
class DmaLatencyRequest {
 public:
  DmaLatencyRequest() = default;
  /// Opens `path` (/dev/cpu_dma_latency) and writes 0. Returns false (with a problem text) if
  /// impossible.
  bool acquire(std::string* problem, const std::string& path = "/dev/cpu_dma_latency");
  ~DmaLatencyRequest();
  DmaLatencyRequest(const DmaLatencyRequest&) = delete;
  DmaLatencyRequest& operator=(const DmaLatencyRequest&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace ftid::rt
