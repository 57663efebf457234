#pragma once
// JSON pieces shared inside ftid::identify (parameter_json.cpp, fit_check.cpp).
#include "ftid/common/types.hpp"
#include "ftid/fileio/json_text.hpp"
#include "ftid/identify/parameter_set.hpp"

namespace ftid::identify {

/// {fx..tz} of `v` (null for a non-finite value).
Json axesJson(const Vec6& v);

/// The object of toJson(set).
Json parameterSetJson(const ParameterSet& set);

}  // namespace ftid::identify
