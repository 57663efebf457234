#pragma once
// Strict YAML loading for ftid's input files. yaml-cpp keeps duplicate keys and returns the first
// one from operator[], so `mass: 1` followed by `mass: -2` would silently be read as 1; the strict
// loader walks the whole document and refuses any mapping that repeats a key, naming both lines.
// It also bounds the nesting depth (ftid's files are at most a few levels deep).
// Readers of ftid's files do not use these directly: they load through YamlFile and read typed
// values through YamlValue (ftid/fileio/yaml_reader.hpp), which builds on this loader.
#include <yaml-cpp/yaml.h>

#include <string>

namespace ftid {

inline constexpr int kMaxYamlDepth = 32;

/// Parses `text` (the contents of `path`, used in messages). Throws ConfigError("PATH:LINE: ...")
/// on a syntax error, a duplicate key or nesting deeper than kMaxYamlDepth.
YAML::Node loadYamlStrict(const std::string& text, const std::string& path);

/// Reads `path` with readInputFile (regular file, O_NONBLOCK, size bound) and loadYamlStrict.
/// `what` names the kind of file ("parameter file").
YAML::Node loadYamlFileStrict(const std::string& path, const std::string& what);

/// Throws ConfigError if any mapping in `root` repeats a key (or nesting is too deep).
void checkNoDuplicateKeys(const YAML::Node& root, const std::string& path);

}  // namespace ftid
