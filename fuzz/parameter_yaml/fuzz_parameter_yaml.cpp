// Fuzz target: parameter files (ftid::params::parseParameterText, the body of readParameterFile).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/params/parameter_set.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ftid::params::ParameterSet set = ftid::params::parseParameterText(text, "fuzz.yaml");
    // Whatever is accepted is usable: finite, positive mass, valid inertia.
    if (ftid::params::findParameterProblem(set)) __builtin_trap();
    (void)ftid::params::toJson(set);
  } catch (const ftid::Error&) {
    // a clear rejection naming file, line and key
  }
  return 0;
}
