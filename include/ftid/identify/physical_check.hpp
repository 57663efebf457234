#pragma once
// Is an identified parameter set physically possible? (docs/identification.md, "Physical
// validity"). `ftid identify` prints the verdict in one line, the same words as `ftid analyze`
// (mass, principal moments of the inertia about the centre of mass, triangle inequalities, within
// the uncertainty), and writes or exports nothing that fails it. The decision is the parameter
// file writer's own rule, params::findParameterProblem, so a set that passes here is a set the
// writer accepts; identify adds one rule of its own: a mass the data do not determine.
#include <optional>
#include <string>

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

/// The verdict on `set` and its one line: the mass (if the model has one), the inertia about the
/// centre of mass (models with rigid_body: effects::inertiaAboutCom with the standard errors of the
/// set) and, when invalid, the key and reason: params::findParameterProblem's, or a mass not
/// determined by the data (standard error above kMaxMassRelativeStd of it).
PhysicalValidity checkPhysicalValidity(const ParameterSet& set);

/// The error text for a set that fails: names the key and the reason, says nothing was written.
std::string physicalRefusal(const PhysicalValidity& validity);

/// The `ftid identify --json` object (identificationJson's keys) plus "physical_validity":
/// {"valid": bool, "key": KEY or null, "reason": TEXT or null, "line": TEXT}.
std::string identificationJson(const ParameterSet& set, const FitCheck& check, const PhysicalValidity& validity);

}  // namespace ftid::identify
