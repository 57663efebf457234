#include "ftid/daemon/reloader.hpp"

#include <exception>
#include <thread>

namespace ftid::daemon {

ParameterReloader::ParameterReloader(OwnedSwapSlot<Compensation>* slot, CompensationFactory factory)
    : slot_(slot), factory_(std::move(factory)) {}

ReloadResult ParameterReloader::reload(const std::string& path,
                                       std::chrono::milliseconds apply_timeout) {
  ReloadResult result;
  std::unique_ptr<Compensation> fresh;
  try {
    fresh = factory_(path);
  } catch (const std::exception& e) {
    ++failed_;
    result.version = slot_->version();
    result.message = e.what();
    return result;
  }
  if (!fresh) {
    ++failed_;
    result.version = slot_->version();
    result.message = path + ": parameter file produced no model";
    return result;
  }
  const std::uint32_t before = slot_->version();
  slot_->post(std::move(fresh));
  ++succeeded_;
  result.ok = true;
  const auto deadline = std::chrono::steady_clock::now() + apply_timeout;
  while (slot_->hasPending() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  result.applied = !slot_->hasPending() && slot_->version() > before;
  result.version = slot_->version();
  if (!result.applied) result.message = "loaded; waiting for the loop to take it into use";
  // The loop retires the previous object when it swaps; free it here (off the loop).
  slot_->collectRetired();
  return result;
}

}  // namespace ftid::daemon
