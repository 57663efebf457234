#include "ftid/drivers/ur/servo_program.hpp"

#include <cmath>
#include <cstdio>

#include "ftid/common/error.hpp"
#include "socket_util.hpp"

namespace ftid::drivers::ur {

namespace {
std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
}  // namespace

std::string buildServoProgram(const ServoProgramConfig& c) {
  if (c.register_offset != 0 && c.register_offset != 24) {
    throw ConfigError("servo program: register_offset must be 0 or 24 (got " + std::to_string(c.register_offset) + ")");
  }
  if (!(c.step_time >= 0.001 && c.step_time <= 0.1)) {
    throw ConfigError("servo program: step_time must be in [0.001, 0.1] s (got " + num(c.step_time) + ")");
  }
  if (!(c.lookahead_time >= 0.03 && c.lookahead_time <= 0.2)) {
    throw ConfigError("servo program: lookahead_time must be in [0.03, 0.2] s (got " + num(c.lookahead_time) + ")");
  }
  if (!(c.gain >= 100.0 && c.gain <= 2000.0)) {
    throw ConfigError("servo program: gain must be in [100, 2000] (got " + num(c.gain) + ")");
  }
  const std::string o = std::to_string(c.register_offset);
  auto in_d = [&](int k) { return "read_input_float_register(" + std::to_string(c.register_offset + k) + ")"; };
  std::string s;
  s += "def " + std::string(kServoProgramName) + "():\n";
  s += "  # ftid servo program (written for ftid; register protocol in docs/robot.md)\n";
  s += "  # register offset " + o + "; defaults t=" + num(c.step_time) + " lookahead=" + num(c.lookahead_time) +
       " gain=" + num(c.gain) + "\n";
  s += "  textmsg(\"ftid_servo: started\")\n";
  s += "  global ftid_target = get_actual_joint_positions()\n";
  s += "  global ftid_t = " + num(c.step_time) + "\n";
  s += "  global ftid_lookahead = " + num(c.lookahead_time) + "\n";
  s += "  global ftid_gain = " + num(c.gain) + "\n";
  s += "  global ftid_count = 0\n";
  s += "  thread ftid_servo_thread():\n";
  s += "    while True:\n";
  s += "      enter_critical\n";
  s += "      q = ftid_target\n";
  s += "      t = ftid_t\n";
  s += "      lh = ftid_lookahead\n";
  s += "      g = ftid_gain\n";
  s += "      exit_critical\n";
  s += "      servoj(q, 0, 0, t, lh, g)\n";
  s += "    end\n";
  s += "  end\n";
  s += "  servo_running = False\n";
  s += "  servo_handle = 0\n";
  s += "  executing = False\n";
  s += "  write_output_integer_register(" + o + ", " + std::to_string(kScriptReady) + ")\n";
  s += "  while True:\n";
  s += "    cmd = read_input_integer_register(" + o + ")\n";
  s += "    if cmd == " + std::to_string(kCmdServoJ) + ":\n";
  s += "      enter_critical\n";
  s += "      ftid_target = [" + in_d(0) + ", " + in_d(1) + ", " + in_d(2) + ", " + in_d(3) + ", " + in_d(4) +
       ", " + in_d(5) + "]\n";
  s += "      if " + in_d(8) + " > 0:\n";
  s += "        ftid_t = " + in_d(8) + "\n";
  s += "      end\n";
  s += "      if " + in_d(9) + " > 0:\n";
  s += "        ftid_lookahead = " + in_d(9) + "\n";
  s += "      end\n";
  s += "      if " + in_d(10) + " > 0:\n";
  s += "        ftid_gain = " + in_d(10) + "\n";
  s += "      end\n";
  s += "      exit_critical\n";
  s += "      ftid_count = ftid_count + 1\n";
  s += "      if ftid_count > 2000000000:\n";
  s += "        ftid_count = 0\n";
  s += "      end\n";
  s += "      write_output_integer_register(" + std::to_string(c.register_offset + 1) + ", ftid_count)\n";
  s += "      if not servo_running:\n";
  s += "        servo_handle = run ftid_servo_thread()\n";
  s += "        servo_running = True\n";
  s += "      end\n";
  s += "      write_output_integer_register(" + o + ", " + std::to_string(kScriptReady) + ")\n";
  s += "    elif cmd == 0:\n";
  s += "      executing = False\n";
  s += "      write_output_integer_register(" + o + ", " + std::to_string(kScriptReady) + ")\n";
  s += "    elif not executing:\n";
  s += "      executing = True\n";
  s += "      if cmd == " + std::to_string(kCmdServoStop) + ":\n";
  s += "        if servo_running:\n";
  s += "          kill servo_handle\n";
  s += "          servo_running = False\n";
  s += "        end\n";
  s += "        stopj(" + in_d(0) + ")\n";
  s += "      elif cmd == " + std::to_string(kCmdSetWatchdog) + ":\n";
  s += "        rtde_set_watchdog(\"input_int_register_" + o + "\", " + in_d(0) + ", \"stop\")\n";
  s += "      elif cmd == " + std::to_string(kCmdStopScript) + ":\n";
  s += "        if servo_running:\n";
  s += "          kill servo_handle\n";
  s += "          servo_running = False\n";
  s += "        end\n";
  s += "        stopj(4.0)\n";
  s += "        write_output_integer_register(" + o + ", " + std::to_string(kScriptDone) + ")\n";
  s += "        break\n";
  s += "      end\n";
  s += "      write_output_integer_register(" + o + ", " + std::to_string(kScriptDone) + ")\n";
  s += "    end\n";
  s += "    sync()\n";
  s += "  end\n";
  s += "  textmsg(\"ftid_servo: stopped\")\n";
  s += "end\n";
  return s;
}

void uploadScript(const std::string& host, std::uint16_t port, const std::string& text,
                  std::chrono::milliseconds timeout) {
  int fd = detail::connectTcp(host, port, timeout, "URScript");
  std::string err;
  const bool ok = detail::sendAll(fd, text.data(), text.size(), timeout, &err);
  detail::closeFd(&fd);
  if (!ok) throw DriverError("URScript upload to " + host + ":" + std::to_string(port) + " failed: " + err);
}

}  // namespace ftid::drivers::ur
