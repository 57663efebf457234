#pragma once
// Scenarios of cell operation for the payload monitor's tests, bench and demo (docs/simulator.md,
// "Operation scenarios"): random pick-and-place-like wrist motion, random contact pushes, an
// object grasped. Every draw is from a seeded std::mt19937_64 (same seed, same scenario).
#include <cstdint>
#include <vector>

#include "ftid/sim/cell_sim.hpp"

namespace ftid::sim {

/// A smooth random motion around the paper's start pose: `harmonics` harmonics of f_base_hz per
/// joint, amplitudes up to about 0.25 rad (joints 1-3) and 0.8 rad (joints 4-6), peak joint speeds
/// of the order of 1 rad/s. Periodic with 1 / f_base_hz.
trajectory::FourierTrajectory randomOperationTrajectory(std::uint64_t seed, double f_base_hz = 0.05,
                                                        int harmonics = 5);

struct PushScenario {
  double force_N = 12.0;          ///< peak force of each push
  double min_duration_s = 0.4;
  double max_duration_s = 0.6;
  double min_gap_s = 1.0;         ///< quiet time between two pushes (at least)
  double max_gap_s = 6.0;         ///< (at most)
  double tool_radius_m = 0.05;    ///< points of application: |x|,|y| <= r, z in [0.02, 0.15] m of S
};

/// Pushes in [t_begin_s, t_end_s]: gaps uniform in [min_gap, max_gap], durations uniform in
/// [min, max], directions uniform on the sphere (in B), sin^2 profile of peak force_N.
std::vector<ContactSwitch> randomPushes(std::uint64_t seed, double t_begin_s, double t_end_s,
                                        const PushScenario& scenario = {});

/// A compact object: mass, centre of mass in S, inertia of a solid cube of side `side_m` about C.
PayloadTruth compactObject(double mass_kg, const Vec3& p_SC_S, double side_m = 0.06);

}  // namespace ftid::sim
