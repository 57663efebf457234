// Model: an ordered composition of effects (include/ftid/effects/model.hpp).
#include "ftid/effects/model.hpp"

#include <algorithm>
#include <limits>

#include "ftid/common/error.hpp"
#include "ftid/effects/signal_source.hpp"

namespace ftid::effects {

namespace {

const std::vector<std::string>& paperEffects() {
  static const std::vector<std::string> k{"offsets", "gravity", "tilt", "linear_inertia"};
  return k;
}

std::vector<std::string> splitPlus(const std::string& name) {
  std::vector<std::string> parts;
  std::string current;
  int depth = 0;  // '+' inside parentheses belongs to an argument list
  for (char ch : name) {
    if (ch == '(') ++depth;
    if (ch == ')') --depth;
    if (ch == '+' && depth == 0) {
      parts.push_back(current);
      current.clear();
    } else {
      current += ch;
    }
  }
  parts.push_back(current);
  for (auto& p : parts) {
    const auto b = p.find_first_not_of(" \t");
    const auto e = p.find_last_not_of(" \t");
    p = (b == std::string::npos) ? std::string() : p.substr(b, e - b + 1);
  }
  return parts;
}

}  // namespace

Model::Model(const Model& other) : index_(other.index_) {
  effects_.reserve(other.effects_.size());
  for (const auto& e : other.effects_) effects_.push_back(e->clone());
  // Clones keep the bound columns (same index), but bind again to be independent of clone().
  for (auto& e : effects_) e->bind(index_);
}

Model& Model::operator=(const Model& other) {
  if (this != &other) {
    Model copy(other);
    *this = std::move(copy);
  }
  return *this;
}

Model Model::fromName(const std::string& name) {
  if (name.find_first_not_of(" \t+") == std::string::npos) {
    throw ConfigError("empty model name (try 'paper' or 'paper+rigid_body')");
  }
  std::vector<std::string> specs;
  for (const auto& part : splitPlus(name)) {
    if (part.empty()) throw ConfigError("model '" + name + "': empty effect name between '+'");
    if (part == "paper") {
      for (const auto& p : paperEffects()) specs.push_back(p);
    } else {
      specs.push_back(part);
    }
  }
  Model model;
  for (const auto& spec : specs) {
    auto effect = createEffect(spec);
    if (model.contains(effect->name())) continue;  // e.g. "paper+gravity": already there
    model.add(std::move(effect));
  }
  model.finalize();
  return model;
}

void Model::add(std::unique_ptr<Effect> effect) {
  // Required effects go in before the effect that needs them.
  for (const auto& req : effect->requires()) {
    if (!contains(req)) add(createEffect(req));
  }
  effects_.push_back(std::move(effect));
}

void Model::finalize() {
  index_ = ParamIndex();
  for (const auto& e : effects_) {
    for (const auto& p : e->params()) index_.add(p.name);
  }
  for (auto& e : effects_) e->bind(index_);
}

std::string Model::name() const {
  std::vector<std::string> names;
  for (const auto& e : effects_) names.push_back(e->name());
  const auto& paper = paperEffects();
  const bool has_paper = std::all_of(paper.begin(), paper.end(), [&](const std::string& p) {
    return std::find(names.begin(), names.end(), p) != names.end();
  });
  std::string out;
  if (has_paper) out = "paper";
  for (const auto& n : names) {
    if (has_paper && std::find(paper.begin(), paper.end(), n) != paper.end()) continue;
    out += (out.empty() ? "" : "+") + n;
  }
  return out;
}

std::vector<ParamInfo> Model::params() const {
  std::vector<ParamInfo> out(static_cast<std::size_t>(index_.size()));
  for (const auto& e : effects_) {
    for (const auto& p : e->params()) out[static_cast<std::size_t>(index_.column(p.name))] = p;
  }
  return out;
}

bool Model::estimatesTilt() const {
  return std::any_of(effects_.begin(), effects_.end(), [](const auto& e) { return e->estimatesTilt(); });
}

std::string Model::tiltAbsorbers() const {
  std::string out;
  for (const auto& e : effects_) {
    if (e->foldsIntoTilt()) out += (out.empty() ? "" : ", ") + e->name();
  }
  return out;
}

bool Model::estimatesMounting() const {
  return std::any_of(effects_.begin(), effects_.end(), [](const auto& e) { return e->estimatesMounting(); });
}

bool Model::estimatesDelay() const {
  return std::any_of(effects_.begin(), effects_.end(), [](const auto& e) { return e->estimatesDelay(); });
}

std::uint32_t Model::signals() const {
  std::uint32_t s = kSignalNone;
  for (const auto& e : effects_) s |= e->signals();
  return s;
}

std::string Model::missingSignal(const SampleContext& ctx) const {
  for (const auto& e : effects_) {
    if ((e->signals() & kSignalTemperature) != 0 && !ctx.has_temp) {
      return "effect " + e->name() + " needs the temp column, which the log does not have";
    }
    for (const auto& name : e->signalNames()) {
      const SignalSource src = SignalSource::parse(name);
      if (src.available(ctx)) continue;
      if (!ctx.has_joints && (src.isAngle() || name.rfind("qd", 0) == 0)) {
        return "effect " + e->name() + " needs the joint signal '" + name +
               "': a pose log gives the sensor pose and has no joint angles";
      }
      return "effect " + e->name() + " needs the signal '" + name + "', which the log does not have";
    }
  }
  return "";
}

std::string Model::cannotFit(const std::vector<SampleContext>& ctx) const {
  if (ctx.empty()) return "";
  std::string miss = missingSignal(ctx.front());
  if (!miss.empty()) return miss;
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, numParams());
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    computeRegressor(ctx[i], Y);
    if (Y.allFinite()) continue;
    Eigen::Index row = 0;
    Eigen::Index col = 0;
    (!Y.array().isFinite()).cast<int>().maxCoeff(&row, &col);
    const std::string param = index_.names()[static_cast<std::size_t>(col)];
    std::string owner = "the model";
    for (const auto& e : effects_) {
      for (const auto& p : e->params()) {
        if (p.name == param) owner = "effect " + e->name();
      }
    }
    return owner + " is not defined at t = " + std::to_string(ctx[i].t) + " s (sample " + std::to_string(i + 1) +
           ", parameter " + param + " on " + kWrenchAxisNames[row] + ")";
  }
  return "";
}

bool Model::contains(const std::string& effect_name) const {
  return std::any_of(effects_.begin(), effects_.end(),
                     [&](const auto& e) { return e->name() == effect_name; });
}

std::optional<Model::MassMinimum> Model::smallestPayloadMass(const std::vector<SampleContext>& ctx,
                                                             const Eigen::VectorXd& theta) const {
  const int cm = index_.column("mass");
  const bool varies = std::any_of(effects_.begin(), effects_.end(), [](const auto& e) { return e->changesPayloadMass(); });
  if (cm < 0 || !varies || ctx.empty() || theta.size() < numParams()) return std::nullopt;
  MassMinimum lowest{std::numeric_limits<double>::infinity(), 0};
  for (std::size_t k = 0; k < ctx.size(); ++k) {
    double m = theta(cm);
    for (const auto& e : effects_) m += e->payloadMassChange(ctx[k], theta);
    if (!(m >= lowest.mass_kg)) lowest = {m, k};  // a NaN mass is the lowest: never physical
  }
  return lowest;
}

void Model::computeRegressor(const SampleContext& ctx,
                             Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) const noexcept {
  Y.setZero();
  for (const auto& e : effects_) e->addRegressor(ctx, Y);
}

Model Model::withEffect(const std::string& effect_name) const {
  auto effect = createEffect(effect_name);
  if (contains(effect->name())) {
    throw ConfigError("model '" + name() + "' already contains effect '" + effect->name() + "'");
  }
  Model out(*this);
  out.add(std::move(effect));
  out.finalize();
  return out;
}

}  // namespace ftid::effects
