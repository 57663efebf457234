#include "ftid/rt/rt_thread.hpp"

#include <pthread.h>

#include <cstring>
#include <exception>

#include "ftid/common/error.hpp"

namespace ftid::rt {

namespace {
struct ThreadArgs {
  const RealtimeConfig* cfg;
  const std::function<void()>* body;
  RealtimeReport* report;
  std::exception_ptr error;
};

void* trampoline(void* p) {
  auto* a = static_cast<ThreadArgs*>(p);
  try {
    configureCurrentThread(*a->cfg, a->report);
    warnOnce(*a->report);
    (*a->body)();
  } catch (...) {
    a->error = std::current_exception();
  }
  return nullptr;
}
}  // namespace

RealtimeReport runInRealtimeThread(const RealtimeConfig& cfg, const std::function<void()>& body) {
  RealtimeReport report;
  lockProcessMemory(cfg, &report);
  DmaLatencyRequest dma;
  if (cfg.enable && cfg.dma_latency) {
    std::string problem;
    // Best effort even with cfg.require (RealtimeConfig::dma_latency says why).
    if (dma.acquire(&problem, cfg.dma_latency_path)) {
      report.dma_latency = true;
    } else {
      report.problems.push_back(problem);
    }
  }
  ThreadArgs args{&cfg, &body, &report, nullptr};
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  if (cfg.stack_size > 0) pthread_attr_setstacksize(&attr, cfg.stack_size);
  pthread_t th;
  const int rc = pthread_create(&th, &attr, &trampoline, &args);
  pthread_attr_destroy(&attr);
  if (rc != 0) throw RealtimeSetupError(std::string("cannot create the loop thread: ") + std::strerror(rc));
  pthread_join(th, nullptr);
  if (args.error) std::rethrow_exception(args.error);
  return report;
}

}  // namespace ftid::rt
