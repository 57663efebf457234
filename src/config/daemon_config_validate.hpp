#pragma once
// ftidd configuration validation (private to src/config): the cross-field and file checks that
// loadDaemonConfig/parseDaemonConfig (daemon_config.cpp) and validateDaemonConfig run on a
// DaemonConfig, section by section, and the LCM URL check (daemon_config_validate.cpp).
#include <functional>
#include <string>
#include <vector>

#include "ftid/config/daemon_config.hpp"

namespace ftid::config::internal {

/// The directory part of a path: "." without a '/', "/" for a file in the root.
std::string dirOf(const std::string& path);

/// Cross-field and file checks; throws ConfigError "WHERE: key 'KEY': problem" for the first
/// failing key, where `where(key)` gives the location prefix for a key. Appends warnings (legal
/// but risky settings) to `warnings` unless it is null.
void validate(const DaemonConfig& c, const std::function<std::string(const std::string&)>& where,
              std::vector<std::string>* warnings);

}  // namespace ftid::config::internal
