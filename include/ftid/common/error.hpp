#pragma once
// Set-up errors are exceptions (this file); the real-time loop uses status values and fault bits
// (ftid/common/status.hpp). Every message names the file, line, column or key it is about.
#include <stdexcept>
#include <string>

namespace ftid {

/// Base of every exception ftid throws at set-up time.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Malformed or inconsistent input data (logs, parameter files): message names file/line/column.
class DataError : public Error {
 public:
  using Error::Error;
};

/// Invalid configuration (YAML, command line): message names the key and the file.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// Data that cannot determine the requested parameters (rank deficiency, too few samples).
class IdentificationError : public Error {
 public:
  using Error::Error;
};

/// A hardware or protocol peer misbehaved during set-up (connect, handshake).
class DriverError : public Error {
 public:
  using Error::Error;
};

/// Real-time set-up (mlockall, SCHED_FIFO, affinity) failed where it was required.
class RealtimeSetupError : public Error {
 public:
  using Error::Error;
};

}  // namespace ftid
