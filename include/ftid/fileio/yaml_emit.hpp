#pragma once
// YAML output through yaml-cpp's emitter (never by string concatenation), with the number policy
// of every file ftid writes: a double is written as the shortest text that reads back as the same
// double (round trip, at most max_digits10 = 17 significant digits; the policy of JSON output,
// json_text.hpp); non-finite values as YAML's .nan / .inf / -.inf (the strict readers refuse them
// where a file must be finite). Strings are quoted by the emitter only where YAML needs it.
//
//   YAML::Emitter out;
//   out << YAML::BeginMap << YAML::Key << "mass" << YAML::Value << ftid::YamlNumber{m} << YAML::EndMap;
//   writeFileAtomically(path, yamlDocument("# header\n", out));
#include <yaml-cpp/yaml.h>

#include <string>

namespace ftid {

/// A double for the emitter (see the policy above).
struct YamlNumber {
  double value;
};

/// The text the policy writes for `v`.
std::string yamlNumberText(double v);

YAML::Emitter& operator<<(YAML::Emitter& out, YamlNumber number);

/// `comment` (lines starting with '#', each ending in '\n', may be empty) followed by the emitted
/// document and a final newline. Throws ConfigError if the emitter is in an error state.
std::string yamlDocument(const std::string& comment, const YAML::Emitter& out);

}  // namespace ftid
