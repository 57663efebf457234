#pragma once
// JSON pieces of a parameter set, shared by toJson (parameter_set.hpp) and identify's fit check
// (`ftid identify --json`), under the one output policy of ftid/fileio/json_text.hpp.
#include "ftid/common/types.hpp"
#include "ftid/fileio/json_text.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::params {

/// {fx..tz} of `v` (null for a non-finite value).
Json axesJson(const Vec6& v);

/// The object of toJson(set).
Json parameterSetJson(const ParameterSet& set);

}  // namespace ftid::params
