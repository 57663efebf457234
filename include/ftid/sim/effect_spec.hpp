#pragma once
// Hidden-effect switches of the cell simulator written as one argument, the form `ftid simulate
// --effect` takes (docs/simulator.md):
//
//   NAME[:key=value,...]     e.g. sensor_delay:tau=0.02   cable:k=5,anchor=-0.7/-0.3/1.4
//
// Vectors use '/' between components (';' also accepted). This is the simulator's configuration
// language, not the model's effect syntax name(arg, ...) (src/effects): it switches on physics the
// identification must discover.
#include <string>

#include "ftid/sim/cell_sim.hpp"

namespace ftid::sim {

/// Switches on the effect `spec` names in `config` with its keys. Throws ConfigError naming the
/// effect and the key for an unknown effect or key, a missing '=', or a value that is not a finite
/// number (or not three of them for a vector).
void applyEffectSpec(const std::string& spec, CellSimConfig& config);

}  // namespace ftid::sim
