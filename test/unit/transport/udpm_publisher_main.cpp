// Test-only publisher for the multi-process udpm test (run inside a private network namespace
// by udpm_netns_test.cpp): publishes COUNT cycle records through an LcmOutbox on URL.
//   ftid_test_udpm_publisher URL COUNT
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <random>
#include <thread>

#include "ftid/transport/lcm_outbox.hpp"
#include "test_records.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s URL COUNT\n", argv[0]);
    return 2;
  }
  try {
    ftid::transport::OutboxOptions opt;
    opt.url = argv[1];
    const int count = std::atoi(argv[2]);
    ftid::transport::LcmOutbox outbox(opt);
    outbox.start();
    std::mt19937_64 rng(5);
    for (int i = 0; i < count; ++i) {
      if (!outbox.tryPush(ftid::transport::test::randomCycleRecord(rng, i))) return 3;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));  // 500 Hz
    }
    if (!outbox.waitIdle(std::chrono::seconds(5))) return 4;
    outbox.stop();
    const auto c = outbox.counters();
    std::printf("published %llu errors %llu\n", static_cast<unsigned long long>(c.published),
                static_cast<unsigned long long>(c.publish_errors));
    return c.publish_errors == 0 ? 0 : 5;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "publisher: %s\n", e.what());
    return 1;
  }
}
