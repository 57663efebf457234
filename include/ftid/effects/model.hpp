#pragma once
// A Model is an ordered composition of effects, named by joining effect names with '+':
//   "paper"                      = offsets + gravity + tilt + linear_inertia (the paper's 12 parameters)
//   "paper+rigid_body+cable"     = the paper model plus two more effects
// Aliases ("paper") are expanded by the registry; required effects are added automatically.
//
// Identity: for every sample, wrench_model = regressor(ctx) * theta, where theta is ordered as
// paramIndex().names().
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"

namespace ftid::effects {

class Model {
 public:
  /// Parses and composes a model name. Throws ConfigError naming the unknown effect and listing
  /// the known ones.
  static Model fromName(const std::string& name);

  Model(const Model&);
  Model& operator=(const Model&);
  Model(Model&&) noexcept = default;
  Model& operator=(Model&&) noexcept = default;
  ~Model() = default;

  /// Canonical name: effects in composition order joined by '+', "paper" re-collapsed.
  std::string name() const;
  const std::vector<std::unique_ptr<Effect>>& effectList() const { return effects_; }
  const ParamIndex& paramIndex() const { return index_; }
  std::vector<ParamInfo> params() const;  ///< in column order
  int numParams() const { return index_.size(); }
  bool estimatesTilt() const;
  bool estimatesMounting() const;
  bool estimatesDelay() const;
  /// The effects whose uniform pull the fitted tilt absorbs (Effect::foldsIntoTilt), joined by
  /// ", "; "" when the model's tilt is the base's mounting tilt.
  std::string tiltAbsorbers() const;
  std::uint32_t signals() const;  ///< union of the effects' signals
  /// Why a sample like `ctx` cannot feed this model: "" if it carries every signal the effects read
  /// (Effect::signalNames, the temperature), else one line naming the effect and the signal.
  std::string missingSignal(const SampleContext& ctx) const;
  /// Why `ctx` cannot feed this model: missingSignal of the first sample, or the first sample at
  /// which an effect's regressor is not finite (an expr dividing by zero there); "" if none.
  std::string cannotFit(const std::vector<SampleContext>& ctx) const;
  bool contains(const std::string& effect_name) const;

  /// Where the payload's mass is smallest over `ctx`, for a model whose mass varies from sample to
  /// sample (an effect with changesPayloadMass, e.g. payload(s)): `mass` + every effect's
  /// payloadMassChange, with the parameters `theta` (ParamIndex columns). nullopt when the model
  /// has no `mass` parameter, no such effect, or `ctx` is empty.
  struct MassMinimum {
    double mass_kg = 0.0;
    std::size_t sample = 0;  ///< index into ctx
  };
  std::optional<MassMinimum> smallestPayloadMass(const std::vector<SampleContext>& ctx, const Eigen::VectorXd& theta) const;

  /// Y (6 x numParams) for one sample; Y is overwritten. Real-time safe if Y is preallocated.
  void computeRegressor(const SampleContext& ctx,
                        Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) const noexcept;

  /// Returns a model with one more effect (for `ftid analyze` candidates).
  Model withEffect(const std::string& effect_name) const;

 private:
  Model() = default;
  void add(std::unique_ptr<Effect> effect);
  void finalize();
  std::vector<std::unique_ptr<Effect>> effects_;
  ParamIndex index_;
};

/// Effect factory: name (possibly with arguments, e.g. "harmonic(q4,2)") -> new effect.
/// Adding a named effect in C++ is one class plus one registration line in the built-in table of
/// src/effects/registry.cpp (an explicit table, because static registrars in a static library are
/// dropped by the linker). Users and tests may also call registerEffect() at run time.
using EffectFactory = std::function<std::unique_ptr<Effect>(const std::string& args)>;
bool registerEffect(const std::string& base_name, const std::string& summary, EffectFactory factory);

struct RegisteredEffect {
  std::string base_name;
  std::string summary;
};
std::vector<RegisteredEffect> registeredEffects();

/// Creates one effect from "name" or "name(args)". Throws ConfigError if unknown.
std::unique_ptr<Effect> createEffect(const std::string& spec);

}  // namespace ftid::effects
