#pragma once
// The parameter set (ftid/params/parameter_set.hpp) of a general fit. identify produces parameter
// sets; the params module below it owns the type, its file I/O and thetaFor, so the daemon reads
// parameter files without linking the solver.
#include "ftid/params/parameter_set.hpp"

namespace ftid::identify {

struct FitResult;

using params::NamedValue;
using params::ParameterSet;

/// Parameter set of a general fit.
ParameterSet toParameterSet(const FitResult& fit);

}  // namespace ftid::identify
