// `ftid check-trajectory`: re-verifies a designed trajectory independently of the optimiser
// (dense sampling, joint limits, floor, keep-out spheres, rest-to-rest) and prints the margins.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/design/trajectory_check.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/cell_limits.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace {

const char* kUsage =
    "usage: ftid check-trajectory TRAJ.yaml [--robot URDF] [--config FILE] [--cell FILE] [--dt S]\n"
    "\n"
    "Re-verifies an excitation trajectory written by `ftid design`, independently of the "
    "optimiser:\n"
    "samples it every dt seconds (default 1 ms) and checks joint position, velocity and "
    "acceleration\n"
    "limits, the tool spheres against the floor plane and the keep-out spheres (forward "
    "kinematics\n"
    "of the sensor), rest-to-rest at both ends and a whole number of base periods. Prints every\n"
    "constraint's worst value and margin.\n"
    "\n"
    "  --robot URDF    robot (default: the one recorded in the file)\n"
    "  --config FILE   check against this design config (config/design.yaml format) instead of "
    "the\n"
    "                  constraints recorded in the file\n"
    "  --cell FILE     the cell's safety limits (floor, keep-out spheres, joint position, speed\n"
    "                  and acceleration limits; more limits ON TOP of the installed\n"
    "                  /etc/ftid/cell_limits.yaml, which always applies when present: --cell only tightens;\n"
    "                  default: the installed file if it exists,\n"
    "                  else the shipped config/cell_limits.yaml). The trajectory's own constraints\n"
    "                  (or --config's) can only tighten them; the limits checked are printed with\n"
    "                  the file each came from\n"
    "  --dt S          sampling step [s] (default 0.001)\n"
    "\n"
    "Exit: 0 all constraints hold, 1 a constraint is violated (listed) or the file is invalid.";

int runCheck(const std::vector<std::string>& argv) {
  using namespace ftid;
  std::string robot, config, traj, cell;
  double dt = 0.001;
  CLI::App app{"ftid check-trajectory"};
  app.add_option("--robot", robot);
  app.add_option("--config", config);
  app.add_option("--cell", cell);
  app.add_option("--dt", dt)->transform(cli::real(cli::positive()));
  app.add_option("TRAJ", traj);
  cli::parse(app, argv);
  if (traj.empty()) throw cli::UsageError("expected exactly one trajectory file");
  const std::vector<std::string> pos{traj};

  const trajectory::TrajectoryFile file = trajectory::readTrajectoryFile(pos[0]);
  if (robot.empty()) robot = file.robot;
  if (robot.empty()) throw cli::UsageError(pos[0] + " records no robot: pass --robot URDF");
  const auto kin = model::RobotKinematics::fromUrdfFile(robot);
  trajectory::TrajectoryConstraints constraints = file.constraints;
  if (!config.empty()) constraints = design::loadDesignConstraints(config, kin, file.q0);
  trajectory::LimitSources sources;  // the installed cell limits always apply; --cell only tightens them
  constraints = trajectory::effectiveConstraints(constraints, config.empty() ? pos[0] : config,
                                                 trajectory::applicableCellLimits(cell), &sources);

  const design::CheckReport report =
      design::checkTrajectory(file.toTrajectory(), kin, constraints, dt);
  std::printf("%s: %.4g s, %d harmonics, base %.4g Hz, robot %s\n", pos[0].c_str(), file.duration_s,
              file.harmonics, file.base_frequency_hz, robot.c_str());
  std::printf("limits checked (a trajectory can only tighten the cell's):\n%s",
              trajectory::describeLimits(constraints, sources).c_str());
  std::printf("%s", report.table().c_str());
  if (report.ok()) {
    std::printf("OK: all constraints hold\n");
    return 0;
  }
  std::printf("VIOLATED:\n");
  for (const auto& v : report.violations()) std::printf("  %s\n", v.c_str());
  return 1;
}

ftid::cli::Registrar reg{{"check-trajectory",
                          "re-verify a designed trajectory (limits, workspace, margins)", kUsage,
                          &runCheck}};

}  // namespace
