// Extra log columns as candidate signals (src/lab/extra_signals.hpp, docs/analyze.md).
#include "extra_signals.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>

#include "ftid/effects/signal_source.hpp"

namespace ftid::lab::detail {

namespace {

bool startsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

}  // namespace

bool isBookkeepingColumn(const std::string& name) {
  static const std::array<const char*, 30> kExact = {
      "host_time", "pose",    "timestamp",     "time",        "stamp",      "seq",          "sequence",  "index",
      "counter",   "cycle",   "sensor_age_ms", "fault_bits",  "robot_mode", "safety_mode",  "runtime_state",
      "phase",     "t_traj",  "robot_timestamp", "px",        "py",         "pz",           "rx",        "ry",
      "rz",        "qx",      "qy",            "qz",          "qw",         "sample",       "frame"};
  if (std::find_if(kExact.begin(), kExact.end(), [&](const char* e) { return name == e; }) != kExact.end()) {
    return true;
  }
  for (const char* p : {"kin_", "q_cmd", "target_", "actual_", "contact_"}) {
    if (startsWith(name, p)) return true;
  }
  return false;
}

bool isSignalName(const std::string& name) {
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_')) return false;
  for (const char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.')) return false;
  }
  // A built-in signal's name (t, temp, q1, wx, ...) reads the kinematics, not the column.
  return effects::SignalSource::parse(name).signals() == effects::kSignalExtraColumn;
}

ExtraSignals extraSignals(const std::vector<SampleContext>& ctx) {
  ExtraSignals out;
  if (ctx.empty() || ctx.front().extra_names == nullptr) return out;
  const auto& names = *ctx.front().extra_names;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (isBookkeepingColumn(names[k])) continue;
    bool usable = true;
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (const auto& c : ctx) {
      if (c.extra == nullptr || c.extra_names == nullptr || c.extra_names->size() != names.size() ||
          !std::isfinite(c.extra[k])) {
        usable = false;
        break;
      }
      lo = std::min(lo, c.extra[k]);
      hi = std::max(hi, c.extra[k]);
    }
    if (!usable || !(hi > lo)) continue;  // a constant column is the offsets' business
    if (!isSignalName(names[k])) {
      out.unnamable.push_back(names[k]);
    } else if (static_cast<int>(out.names.size()) < kMaxExtraSignals) {
      out.names.push_back(names[k]);
    } else {
      out.left_out.push_back(names[k]);
    }
  }
  return out;
}

std::vector<std::string> extraSignalCandidates(const std::vector<std::string>& signals) {
  std::vector<std::string> out;
  for (const auto& s : signals) {
    out.push_back("payload(" + s + ")");
    out.push_back("poly(" + s + ",1)");
  }
  return out;
}

std::vector<std::string> withExtraSignals(std::vector<std::string> menu, const AnalyzeOptions& options,
                                          const std::vector<SampleContext>& ctx, std::vector<std::string>* warnings) {
  if (!options.candidates.empty()) return menu;  // the user's menu, as given
  menu.erase(std::remove(menu.begin(), menu.end(), std::string("payload")), menu.end());
  const ExtraSignals extra = extraSignals(ctx);
  for (auto& c : extraSignalCandidates(extra.names)) menu.push_back(std::move(c));
  const auto joined = [](const std::vector<std::string>& v) {
    std::string list;
    for (const auto& n : v) list += (list.empty() ? "'" : ", '") + n + "'";
    return list;
  };
  if (!extra.left_out.empty() && warnings != nullptr) {
    warnings->push_back("only the first " + std::to_string(kMaxExtraSignals) +
                        " extra columns are tried as candidate signals; not tried: " + joined(extra.left_out) +
                        " (name one with --candidates 'payload(<column>)')");
  }
  if (!extra.unnamable.empty() && warnings != nullptr) {
    warnings->push_back("extra columns not tried as candidate signals (an effect's signal is a name of letters, "
                        "digits, '_' and '.', not a built-in signal's): " + joined(extra.unnamable) +
                        "; rename the column to try it");
  }
  return menu;
}

}  // namespace ftid::lab::detail
