#pragma once
// Two halves of an O(N) pass on two threads (private to ftid::identify): the fit's pass over the
// samples, its scores and the Newey-West sum of uncertainty.cpp. The split depends on the number
// of rows alone (never on the machine), so the partial sums and the result are the same with one
// core or two.
#include <exception>
#include <system_error>
#include <thread>

namespace ftid::identify::internal {

/// From this many rows (samples) a pass runs in two halves. Below it, starting a thread and the
/// second core's wake-up cost more than they save (measured at 1,251 samples; docs/performance.md).
constexpr int kParallelRows = 4096;

/// Runs other() on a new thread and here() on this one and waits for both; false (neither ran) on
/// a machine with one core or when no thread can be started, so the caller runs them in turn. An
/// exception from either is rethrown here after both have finished.
template <class Other, class Here>
bool runConcurrently(const Other& other, const Here& here) {
  if (std::thread::hardware_concurrency() < 2) return false;
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

}  // namespace ftid::identify::internal
