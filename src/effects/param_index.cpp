// ParamIndex: parameter name -> regressor column, for one composed model.
#include <algorithm>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

int ParamIndex::column(const std::string& name) const {
  const auto it = std::find(names_.begin(), names_.end(), name);
  return it == names_.end() ? -1 : static_cast<int>(it - names_.begin());
}

void ParamIndex::add(const std::string& name) {
  if (column(name) >= 0) {
    throw ConfigError("model parameter '" + name + "' is defined by two effects");
  }
  names_.push_back(name);
}

int requireColumn(const ParamIndex& index, const std::string& param, const std::string& effect) {
  const int c = index.column(param);
  if (c < 0) {
    throw ConfigError("effect '" + effect + "' needs parameter '" + param +
                      "', which no effect of the model defines");
  }
  return c;
}

}  // namespace ftid::effects
