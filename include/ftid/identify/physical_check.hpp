#pragma once
// Is an identified parameter set physically possible? (docs/identification.md, "Physical
// validity"). `ftid identify` prints the verdict in one line, the same words as `ftid analyze`
// (mass, principal moments of the inertia about the centre of mass, triangle inequalities, within
// the uncertainty), and writes or exports nothing that fails it. The decision is the parameter
// file writer's own rule, params::findParameterProblem, so a set that passes here is a set the
// writer accepts; identify adds one rule of its own: a mass the data do not determine.
#include <optional>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/fit_parameters.hpp"

namespace ftid::identify {

/// A mass whose standard error exceeds this fraction of its value is "not determined" (refused).
inline constexpr double kMaxMassRelativeStd = 1.0 / 3.0;

struct PhysicalValidity {
  bool valid = true;                          ///< findParameterProblem found nothing
  std::optional<params::ParameterProblem> problem;
  std::string line;                           ///< "physical validity: ..." (no newline)
};

/// A payload mass that moves with a signal (payload(s)): its smallest value over the fitted samples
/// (effects::Model::smallestPayloadMass), which must be positive like the mass itself.
struct VaryingMass {
  double mass_kg = 0.0;
  double t_s = 0.0;     ///< where it is smallest [s since the log's first sample]
  std::string effects;  ///< the effects that move it, e.g. "payload(grip)"
};

/// The smallest mass `set`'s model gives over `samples`, or nullopt when its mass does not move with
/// a signal (or the set has no mass).
std::optional<VaryingMass> varyingMass(const ParameterSet& set, const std::vector<effects::SampleContext>& samples);

/// The verdict on `set` and its one line: the mass (if the model has one), the inertia about the
/// centre of mass (models with rigid_body: effects::inertiaAboutCom with the standard errors of the
/// set) and, when invalid, the key and reason: params::findParameterProblem's, or a mass not
/// determined by the data (standard error above kMaxMassRelativeStd of it).
PhysicalValidity checkPhysicalValidity(const ParameterSet& set);
/// The same, and a mass that moves with a signal refused where it is not positive at some sample
/// (key "parameters.mass").
PhysicalValidity checkPhysicalValidity(const ParameterSet& set, const std::optional<VaryingMass>& varying);

/// The error text for a set that fails: names the key and the reason, says nothing was written.
std::string physicalRefusal(const PhysicalValidity& validity);

/// The `ftid identify --json` object (identificationJson's keys) plus "physical_validity":
/// {"valid": bool, "key": KEY or null, "reason": TEXT or null, "line": TEXT}.
std::string identificationJson(const ParameterSet& set, const FitCheck& check, const PhysicalValidity& validity);

}  // namespace ftid::identify
