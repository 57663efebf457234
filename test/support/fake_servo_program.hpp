#pragma once
// The register protocol of ftid's servo program (docs/robot.md, servo_program.cpp), one program
// iteration per controller tick, for fake arms: command 11 takes a target and answers ready (1);
// 0 clears and answers ready; any other command runs once until cleared and answers done (2);
// command 35 arms the RTDE watchdog. Header-only, allocation-free.
#include <cstdint>

namespace ftid::test {

struct FakeServoProgram {
  std::int32_t command = 0;  ///< input_int_register_o as last written by the client
  std::int32_t script = 1;   ///< output_int_register_o
  bool executing = false;
  bool watchdog_armed = false;
  bool ignore_watchdog = false;  ///< a program that never confirms command 35 (fault injection)
  int watchdog_requests = 0;     ///< times command 35 was executed

  /// One iteration of the program's main loop (called once per controller tick).
  void step() noexcept {
    if (command == 11) {
      script = 1;
    } else if (command == 0) {
      executing = false;
      script = 1;
    } else if (!executing) {
      if (command == 35 && ignore_watchdog) return;
      executing = true;
      if (command == 35) {
        watchdog_armed = true;
        ++watchdog_requests;
      }
      script = 2;
    }
  }
};

}  // namespace ftid::test
