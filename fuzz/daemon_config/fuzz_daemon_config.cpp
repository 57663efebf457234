// Fuzz target: ftidd's configuration (ftid::config::parseDaemonConfig). Relative file names
// resolve against the source tree's config/ so a valid document can reach every check.
#include <cstddef>
#include <cstdint>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "test_paths.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ftid::config::DaemonConfig c =
        ftid::config::parseDaemonConfig(text, "fuzz.yaml", ftid::test::sourcePath("/config"));
    (void)ftid::config::describeDaemonConfig(c);
  } catch (const ftid::Error&) {
    // a clear rejection naming file, line and key
  }
  return 0;
}
