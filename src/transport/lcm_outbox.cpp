#include "ftid/common/clock.hpp"
#include "ftid/transport/lcm_outbox.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_log.hpp"
#include "ftid/rt/spsc_queue.hpp"

namespace ftid::transport {
namespace {

constexpr std::size_t kMaxChannelLength = 63;  // LCM_MAX_CHANNEL_NAME_LENGTH

std::int64_t nowUtime() { return realtimeUs(); }

void checkChannel(const std::string& key, const std::string& name) {
  if (name.empty() || name.size() > kMaxChannelLength) {
    throw ConfigError("LCM channel '" + key + "' = '" + name +
                      "': must be 1 to 63 characters long");
  }
}

}  // namespace

struct LcmOutbox::Impl {
  OutboxOptions options;
  std::unique_ptr<lcm::LCM> owned_lcm;
  lcm::LCM* lcm = nullptr;
  rt::SpscQueue<CycleRecord, kQueueCapacity> queue;
  int event_fd = -1;
  std::thread thread;
  std::atomic<bool> running{false};
  bool started = false;

  // Publisher-thread state (preallocated).
  CycleRecord record;
  ftid_lcm::cycle_sample_t cycle_msg{};
  ftid_lcm::compensated_wrench_t wrench_msg{};
  std::vector<std::uint8_t> cycle_buf;
  std::vector<std::uint8_t> wrench_buf;

  std::mutex publish_mutex;  // serialises publish + record between the publisher and other threads
  std::unique_ptr<LcmLogWriter> recorder;
  bool record_error_reported = false;

  CommandHandler command_handler = nullptr;
  void* command_context = nullptr;
  // The command_t subscription on *lcm while started; removed by stop() so that a shared LCM
  // instance (which outlives the outbox) never dispatches to this Impl after stop or destruction.
  lcm::Subscription* command_subscription = nullptr;

  std::atomic<std::uint64_t> pushed{0};
  std::atomic<std::uint64_t> processed{0};
  std::atomic<std::uint64_t> published{0};
  std::atomic<std::uint64_t> publish_errors{0};
  std::atomic<std::uint64_t> recorded{0};
  std::atomic<std::uint64_t> commands{0};
  std::atomic<std::uint64_t> malformed{0};
  ftid_lcm::command_t received_command;  // decoded into on the publisher thread

  int publishLocked(const std::string& channel, const void* data, unsigned size) {
    std::lock_guard<std::mutex> lock(publish_mutex);
    const int rc = lcm->publish(channel, data, size);
    if (rc == 0) {
      published.fetch_add(1, std::memory_order_relaxed);
    } else {
      publish_errors.fetch_add(1, std::memory_order_relaxed);
    }
    if (recorder) {
      try {
        recorder->write(nowUtime(), channel, data, size);
        recorded.fetch_add(1, std::memory_order_relaxed);
      } catch (const Error& e) {
        if (!record_error_reported) {
          std::fprintf(stderr, "ftidd: recording stopped: %s\n", e.what());
          record_error_reported = true;
        }
        recorder.reset();
      }
    }
    return rc;
  }

  void publishRecord() {
    if (options.publish_cycle) {
      toLcm(record, &cycle_msg);
      const int n = encodeInto(cycle_msg, cycle_buf.data(), cycle_buf.size());
      if (n > 0) publishLocked(options.channels.cycle, cycle_buf.data(), static_cast<unsigned>(n));
    }
    if (options.publish_wrench) {
      toLcm(record, &wrench_msg);
      const int n = encodeInto(wrench_msg, wrench_buf.data(), wrench_buf.size());
      if (n > 0) publishLocked(options.channels.wrench, wrench_buf.data(), static_cast<unsigned>(n));
    }
  }

  void drainQueue() {
    while (queue.tryPop(&record)) {
      publishRecord();
      processed.fetch_add(1, std::memory_order_release);
    }
  }

  // Subscribed with LCM's function-pointer form (subscribeFunction), not its member-function
  // form: GCC 12's -fsanitize=vptr miscompiles the pointer-to-member call in LCM 1.3.1's
  // lcm-cpp-impl.hpp:88 (`(subs->handler->*subs->handlerMethod)(...)`) and reports a false
  // "invalid vptr" for every message. Reproduction without LCM:
  // test/unit/transport/gcc_vptr_pmf_repro.cpp.
  // The raw form, not the typed one: LCM's typed handler calls lcm-gen's decoder unguarded, and
  // that decoder throws std::length_error on a string length of 0 (one 69-byte datagram ended
  // ftidd, issue 26). Here the bytes go through transport::tryDecode; a malformed message is
  // dropped, counted (counters().malformed, in loop_stats_t's commands_refused_malformed) and
  // logged (the first and then every 2^k-th), and nothing thrown reaches LCM's C callback.
  static void onCommandBytes(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/,
                             Impl* self) noexcept {
    self->commands.fetch_add(1, std::memory_order_relaxed);
    const char* problem = tryDecode(rbuf->data, rbuf->data_size, &self->received_command);
    if (problem != nullptr) {
      const std::uint64_t n = self->malformed.fetch_add(1, std::memory_order_relaxed) + 1;
      if ((n & (n - 1)) == 0) {
        std::fprintf(stderr, "ftidd: malformed command_t dropped (%u bytes: %s); %llu so far\n",
                     rbuf->data_size, problem, static_cast<unsigned long long>(n));
      }
      return;
    }
    if (self->command_handler == nullptr) return;
    try {
      self->command_handler(self->received_command, self->command_context);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ftidd: command handler failed: %s\n", e.what());
    } catch (...) {
      std::fprintf(stderr, "ftidd: command handler failed\n");
    }
  }

  void run(int lcm_fd) {
    while (running.load(std::memory_order_acquire)) {
      pollfd fds[2] = {{event_fd, POLLIN, 0}, {lcm_fd, POLLIN, 0}};
      const int nfds = lcm_fd >= 0 ? 2 : 1;
      const int rc = ::poll(fds, static_cast<nfds_t>(nfds), 100);
      if (rc > 0 && (fds[0].revents & POLLIN) != 0) {
        std::uint64_t value = 0;
        if (::read(event_fd, &value, sizeof value) < 0 && errno != EAGAIN) {
          std::perror("ftidd: outbox eventfd read");
        }
      }
      drainQueue();
      if (rc > 0 && nfds == 2 && (fds[1].revents & POLLIN) != 0) {
        lcm->handleTimeout(0);
      }
    }
    drainQueue();
  }
};

LcmOutbox::LcmOutbox(OutboxOptions options) : LcmOutbox(std::move(options), nullptr) {}

LcmOutbox::LcmOutbox(OutboxOptions options, lcm::LCM* shared_lcm) : impl_(std::make_unique<Impl>()) {
  checkChannel("cycle", options.channels.cycle);
  checkChannel("wrench", options.channels.wrench);
  checkChannel("stats", options.channels.stats);
  checkChannel("command", options.channels.command);
  checkChannel("ack", options.channels.ack);
  impl_->options = std::move(options);
  warmUpCodec();
  if (shared_lcm != nullptr) {
    impl_->lcm = shared_lcm;
  } else {
    impl_->owned_lcm = std::make_unique<lcm::LCM>(impl_->options.url);
    impl_->lcm = impl_->owned_lcm.get();
  }
  if (!impl_->lcm->good()) {
    throw DriverError("LCM: cannot create provider for URL '" + impl_->options.url +
                      "' (for udpm:// a multicast route is needed, e.g. `ip route add "
                      "224.0.0.0/4 dev lo`; see docs/daemon.md)");
  }
  impl_->cycle_buf.resize(static_cast<std::size_t>(encodedSize(impl_->cycle_msg)));
  impl_->wrench_buf.resize(static_cast<std::size_t>(encodedSize(impl_->wrench_msg)));
  impl_->event_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (impl_->event_fd < 0) {
    throw Error(std::string("LCM outbox: eventfd: ") + std::strerror(errno));
  }
  if (!impl_->options.record_path.empty()) {
    impl_->recorder = std::make_unique<LcmLogWriter>(impl_->options.record_path);
  }
}

LcmOutbox::~LcmOutbox() {
  stop();
  if (impl_->event_fd >= 0) ::close(impl_->event_fd);
}

void LcmOutbox::setCommandHandler(CommandHandler handler, void* context) {
  impl_->command_handler = handler;
  impl_->command_context = context;
}

void LcmOutbox::start() {
  if (impl_->started) return;
  impl_->started = true;
  int lcm_fd = -1;
  if (impl_->command_handler != nullptr) {
    // Subscribed here (a normal thread) so that commands sent right after start() are seen.
    impl_->command_subscription = impl_->lcm->subscribeFunction(
        impl_->options.channels.command, &Impl::onCommandBytes, impl_.get());
    if (impl_->owned_lcm && !impl_->options.allowed_sources.empty()) {
      try {
        restrictLcmSources(*impl_->lcm, impl_->options.url, impl_->options.allowed_sources);
      } catch (...) {
        impl_->lcm->unsubscribe(impl_->command_subscription);
        impl_->command_subscription = nullptr;
        impl_->started = false;
        throw;
      }
    }
    lcm_fd = impl_->lcm->getFileno();
  }
  impl_->running.store(true, std::memory_order_release);
  impl_->thread = std::thread([this, lcm_fd] { impl_->run(lcm_fd); });
}

void LcmOutbox::stop() {
  if (impl_->started) {
    impl_->running.store(false, std::memory_order_release);
    const std::uint64_t one = 1;
    (void)!::write(impl_->event_fd, &one, sizeof one);
    if (impl_->thread.joinable()) impl_->thread.join();
    // After the join nothing handles *lcm on our behalf any more: drop the subscription so a
    // shared instance handled later (or a restart) cannot reach this Impl through it.
    if (impl_->command_subscription != nullptr) {
      impl_->lcm->unsubscribe(impl_->command_subscription);
      impl_->command_subscription = nullptr;
    }
    impl_->started = false;
  }
  std::lock_guard<std::mutex> lock(impl_->publish_mutex);
  if (impl_->recorder) {
    try {
      impl_->recorder->flush();
    } catch (const Error& e) {
      std::fprintf(stderr, "ftidd: %s\n", e.what());
    }
    impl_->recorder.reset();
  }
}

bool LcmOutbox::tryPush(const CycleRecord& record) noexcept {
  if (!impl_->queue.tryPush(record)) return false;
  impl_->pushed.fetch_add(1, std::memory_order_relaxed);
  const std::uint64_t one = 1;
  (void)!::write(impl_->event_fd, &one, sizeof one);
  return true;
}

void LcmOutbox::publishStats(const LoopStatsRecord& stats) {
  ftid_lcm::loop_stats_t msg{};
  toLcm(stats, &msg);
  std::uint8_t buf[512];
  const int n = encodeInto(msg, buf, sizeof buf);
  if (n > 0) impl_->publishLocked(impl_->options.channels.stats, buf, static_cast<unsigned>(n));
}

void LcmOutbox::publishAck(const ftid_lcm::ack_t& ack) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(ack.getEncodedSize()));
  const int n = ack.encode(buf.data(), 0, static_cast<int>(buf.size()));
  if (n > 0) impl_->publishLocked(impl_->options.channels.ack, buf.data(), static_cast<unsigned>(n));
}

int LcmOutbox::publishRaw(const std::string& channel, const void* data, unsigned size) {
  return impl_->publishLocked(channel, data, size);
}

bool LcmOutbox::waitIdle(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const std::uint64_t target = impl_->pushed.load(std::memory_order_relaxed);
  while (impl_->processed.load(std::memory_order_acquire) < target) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

LcmOutbox::Counters LcmOutbox::counters() const noexcept {
  Counters c;
  c.pushed = impl_->pushed.load(std::memory_order_relaxed);
  c.dropped = impl_->queue.dropped();
  c.published = impl_->published.load(std::memory_order_relaxed);
  c.publish_errors = impl_->publish_errors.load(std::memory_order_relaxed);
  c.recorded = impl_->recorded.load(std::memory_order_relaxed);
  c.commands = impl_->commands.load(std::memory_order_relaxed);
  c.malformed = impl_->malformed.load(std::memory_order_relaxed);
  return c;
}

const OutboxOptions& LcmOutbox::options() const noexcept { return impl_->options; }

}  // namespace ftid::transport
