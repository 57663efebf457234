#pragma once
// Runs a body on a dedicated loop thread with an explicit stack size, real-time scheduling and
// affinity (rt_setup.hpp), and waits for it. Other threads of the process stay SCHED_OTHER.
// A set-up failure with cfg.require == true is rethrown on the caller's thread as
// RealtimeSetupError; otherwise the body runs as a normal thread after one warning.
#include <functional>

#include "ftid/rt/rt_setup.hpp"

namespace ftid::rt {

/// Blocks until body() returns. Exceptions escaping body() are rethrown here.
RealtimeReport runInRealtimeThread(const RealtimeConfig& cfg, const std::function<void()>& body);

}  // namespace ftid::rt
