#pragma once
// JSON pieces shared inside ftid::identify (fit_check.cpp); the parameter set's own are in params.
#include "ftid/params/parameter_json.hpp"

namespace ftid::identify {

using params::axesJson;
using params::parameterSetJson;

}  // namespace ftid::identify
