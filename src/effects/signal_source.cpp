// SignalSource: named scalar signals of a SampleContext (include/ftid/effects/signal_source.hpp).
#include "ftid/effects/signal_source.hpp"

#include <algorithm>
#include <limits>

#include "ftid/common/error.hpp"

namespace ftid::effects {

SignalSource SignalSource::parse(const std::string& name) {
  if (name.empty()) throw ConfigError("empty signal name (e.g. t, temp, q4, wz or a log column)");
  SignalSource s;
  s.name_ = name;
  auto axis = [](char c) { return c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1; };
  if (name == "t") {
    s.kind_ = Kind::kTime;
  } else if (name == "temp") {
    s.kind_ = Kind::kTemp;
  } else if (name.size() == 2 && name[0] == 'q' && name[1] >= '1' && name[1] <= '6') {
    s.kind_ = Kind::kJointAngle;
    s.index_ = name[1] - '1';
  } else if (name.size() == 3 && name[0] == 'q' && name[1] == 'd' && name[2] >= '1' && name[2] <= '6') {
    s.kind_ = Kind::kJointVelocity;
    s.index_ = name[2] - '1';
  } else if (name.size() == 2 && name[0] == 'w' && axis(name[1]) >= 0) {
    s.kind_ = Kind::kAngVel;
    s.index_ = axis(name[1]);
  } else if (name.size() == 3 && name[0] == 'a' && name[1] == 'l' && axis(name[2]) >= 0) {
    s.kind_ = Kind::kAngAcc;
    s.index_ = axis(name[2]);
  } else if (name.size() == 2 && name[0] == 'a' && axis(name[1]) >= 0) {
    s.kind_ = Kind::kLinAcc;
    s.index_ = axis(name[1]);
  } else if (name.size() == 2 && name[0] == 'g' && axis(name[1]) >= 0) {
    s.kind_ = Kind::kGravity;
    s.index_ = axis(name[1]);
  } else {
    s.kind_ = Kind::kExtra;
  }
  return s;
}

double SignalSource::read(const SampleContext& ctx) const noexcept {
  switch (kind_) {
    case Kind::kTime: return ctx.t_model;
    case Kind::kTemp: return ctx.temp_degC;
    case Kind::kJointAngle: return ctx.q(index_);
    case Kind::kJointVelocity: return ctx.qd(index_);
    case Kind::kAngVel: return ctx.w_S(index_);
    case Kind::kAngAcc: return ctx.alpha_S(index_);
    case Kind::kLinAcc: return ctx.a_S(index_);
    case Kind::kGravity: return ctx.g_S(index_);
    case Kind::kExtra:
      if (ctx.extra != nullptr && ctx.extra_names != nullptr) {
        const auto& names = *ctx.extra_names;
        for (std::size_t k = 0; k < names.size(); ++k) {
          if (names[k] == name_) return ctx.extra[k];
        }
      }
      return std::numeric_limits<double>::quiet_NaN();
  }
  return 0.0;
}

bool SignalSource::available(const SampleContext& ctx) const noexcept {
  if (kind_ == Kind::kTemp) return ctx.has_temp;
  if (kind_ == Kind::kJointAngle || kind_ == Kind::kJointVelocity) return ctx.has_joints;
  if (kind_ != Kind::kExtra) return true;
  if (ctx.extra == nullptr || ctx.extra_names == nullptr) return false;
  for (const auto& n : *ctx.extra_names) {
    if (n == name_) return true;
  }
  return false;
}

std::string SignalSource::unit() const {
  switch (kind_) {
    case Kind::kTime: return "s";
    case Kind::kTemp: return "degC";
    case Kind::kJointAngle: return "rad";
    case Kind::kJointVelocity: return "rad/s";
    case Kind::kAngVel: return "rad/s";
    case Kind::kAngAcc: return "rad/s^2";
    case Kind::kLinAcc: return "m/s^2";
    case Kind::kGravity: return "m/s^2";
    case Kind::kExtra: return "1";
  }
  return "1";
}

std::uint32_t SignalSource::signals() const {
  switch (kind_) {
    case Kind::kTime: return kSignalTime;
    case Kind::kTemp: return kSignalTemperature;
    case Kind::kExtra: return kSignalExtraColumn;
    default: return kSignalNone;
  }
}

std::vector<std::string> extraColumnsRead(const Model& model) {
  std::vector<std::string> out;
  for (const auto& e : model.effectList()) {
    for (const auto& name : e->signalNames()) {
      if ((SignalSource::parse(name).signals() & kSignalExtraColumn) == 0) continue;
      if (std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
    }
  }
  return out;
}

}  // namespace ftid::effects
