#include "ftid/rt/rt_setup.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "ftid/common/error.hpp"

namespace ftid::rt {

namespace {
void fail(const RealtimeConfig& cfg, RealtimeReport* report, const std::string& what) {
  if (cfg.require) throw RealtimeSetupError("real-time set-up required but failed: " + what);
  report->problems.push_back(what);
}
}  // namespace

std::string RealtimeReport::describe() const {
  std::string s = fifo ? "SCHED_FIFO" : "SCHED_OTHER (no real-time priority)";
  s += memory_locked ? ", memory locked" : ", memory not locked";
  if (pinned) s += ", pinned";
  if (dma_latency) s += ", cpu_dma_latency=0";
  s += realtime_kernel ? ", PREEMPT_RT kernel" : ", non-RT kernel";
  return s;
}

bool hasRealtimeKernel() noexcept {
  std::FILE* f = std::fopen("/sys/kernel/realtime", "r");
  if (!f) return false;
  int v = 0;
  const bool ok = std::fscanf(f, "%d", &v) == 1 && v == 1;
  std::fclose(f);
  return ok;
}

void lockProcessMemory(const RealtimeConfig& cfg, RealtimeReport* report) {
  report->realtime_kernel = hasRealtimeKernel();
  if (!cfg.enable || !cfg.lock_memory) return;
  static std::atomic<bool> locked{false};  // process-wide: lock once
  if (locked.load()) {
    report->memory_locked = true;
    return;
  }
  // With RLIMIT_MEMLOCK finite and no CAP_IPC_LOCK, mlockall(MCL_FUTURE) succeeds but later
  // allocations beyond the limit fail (docs/daemon.md): refuse to lock in that case.
  rlimit lim{};
  getrlimit(RLIMIT_MEMLOCK, &lim);
  const bool unlimited = lim.rlim_cur == RLIM_INFINITY;
  const bool root = geteuid() == 0;
  if (!unlimited && !root && lim.rlim_cur < (std::uint64_t{1} << 30)) {
    fail(cfg, report,
         "mlockall skipped: RLIMIT_MEMLOCK is " + std::to_string(lim.rlim_cur / 1024) +
             " KiB (set LimitMEMLOCK=infinity or grant CAP_IPC_LOCK)");
    return;
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    fail(cfg, report, std::string("mlockall failed: ") + std::strerror(errno));
    return;
  }
  mallopt(M_TRIM_THRESHOLD, -1);
  mallopt(M_MMAP_MAX, 0);
  report->memory_locked = true;
  locked = true;
}

void prefaultStack(std::size_t bytes) noexcept {
  if (bytes == 0) return;
  auto* buf = static_cast<volatile unsigned char*>(alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += 4096) buf[i] = 0;
}

void configureCurrentThread(const RealtimeConfig& cfg, RealtimeReport* report) {
  if (!cfg.enable) return;
  prefaultStack(cfg.stack_prefault_bytes);
  sched_param sp{};
  sp.sched_priority = cfg.priority;
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);  // returns the error
  if (rc != 0) {
    fail(cfg, report,
         "SCHED_FIFO " + std::to_string(cfg.priority) + " refused: " + std::strerror(rc) +
             " (needs root, CAP_SYS_NICE or LimitRTPRIO)");
  } else {
    report->fifo = true;
  }
  if (cfg.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cfg.cpu, &set);
    const int arc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    if (arc != 0) {
      fail(cfg, report, "pinning to CPU " + std::to_string(cfg.cpu) + " failed: " + std::strerror(arc));
    } else {
      report->pinned = true;
    }
  }
}

void warnOnce(const RealtimeReport& report) {
  static std::atomic<bool> warned{false};
  if (report.problems.empty() || warned.exchange(true)) return;
  std::fprintf(stderr, "ftid: running without full real-time guarantees (%s):\n", report.describe().c_str());
  for (const auto& p : report.problems) std::fprintf(stderr, "  - %s\n", p.c_str());
}

bool DmaLatencyRequest::acquire(std::string* problem, const std::string& path) {
  if (fd_ >= 0) return true;
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    if (problem) {
      *problem = path + ": " + std::strerror(errno) +
                 " (power management only; root, or a udev rule for group ftid, and a unit "
                 "without PrivateDevices, can hold it at 0)";
    }
    return false;
  }
  const std::int32_t zero = 0;
  if (::write(fd, &zero, sizeof zero) != static_cast<ssize_t>(sizeof zero)) {
    if (problem) *problem = path + " write: " + std::strerror(errno);
    ::close(fd);
    return false;
  }
  fd_ = fd;
  return true;
}

DmaLatencyRequest::~DmaLatencyRequest() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace ftid::rt
