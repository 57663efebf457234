#pragma once
// Two halves of an O(N) pass on two threads (private to ftid::identify): the fit's pass over the
// samples, its scores and the Newey-West sum of uncertainty.cpp. The split depends on the number
// of rows alone (never on the machine), so the partial sums and the result are the same with one
// core or two.
#include <sched.h>

#include <atomic>
#include <exception>
#include <system_error>
#include <thread>

namespace ftid::identify::internal {

/// From this many rows (samples) a pass runs in two halves. Below it, starting a thread and the
/// second core's wake-up cost more than they save (measured at 1,251 samples; docs/performance.md).
constexpr int kParallelRows = 4096;

/// Tests: true makes tryRunConcurrently decline (runHalves then runs both halves in turn), to show
/// that the result does not depend on it.
inline std::atomic<bool>& serialOnly() {
  static std::atomic<bool> flag{false};
  return flag;
}

/// The CPUs this thread may run on (its affinity mask, e.g. under taskset or a cgroup cpuset).
inline int usableCpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return static_cast<int>(std::thread::hardware_concurrency());
  return CPU_COUNT(&set);
}

/// Runs other() on a new thread and here() on this one and waits for both; false (neither ran)
/// when this thread may use one CPU only, no thread can be started, or serialOnly() is set. An
/// exception from either is rethrown here after both finished. Callers use runHalves().
template <class Other, class Here>
bool tryRunConcurrently(const Other& other, const Here& here) {
  if (serialOnly().load() || usableCpus() < 2) return false;
  std::exception_ptr other_error;
  std::thread worker;
  try {
    worker = std::thread([&other, &other_error] {
      try {
        other();
      } catch (...) {
        other_error = std::current_exception();
      }
    });
  } catch (const std::system_error&) {
    return false;
  }
  std::exception_ptr here_error;
  try {
    here();
  } catch (...) {
    here_error = std::current_exception();
  }
  worker.join();
  if (here_error) std::rethrow_exception(here_error);
  if (other_error) std::rethrow_exception(other_error);
  return true;
}

/// Runs both halves of a pass, first() and second(): second() on a thread of its own when one
/// can be started and this thread may use two CPUs (tryRunConcurrently), else first() then
/// second() on this thread. The halves write separate results, so the outcome is the same either
/// way; an exception from either is rethrown here after both finished.
template <class First, class Second>
void runHalves(const First& first, const Second& second) {
  if (!tryRunConcurrently(second, first)) {
    first();
    second();
  }
}

}  // namespace ftid::identify::internal
