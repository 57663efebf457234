// Operation scenarios (include/ftid/sim/scenarios.hpp).
#include "ftid/sim/scenarios.hpp"

#include <cmath>
#include <random>

#include "ftid/sim/cell_sim.hpp"

namespace ftid::sim {

trajectory::FourierTrajectory randomOperationTrajectory(std::uint64_t seed, double f_base_hz, int harmonics) {
  using Coefficients = std::array<std::array<double, trajectory::FourierTrajectory::kMaxHarmonics>, kNumJoints>;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Coefficients a{}, b{};
  const double w = 2.0 * 3.141592653589793 * f_base_hz;
  for (int j = 0; j < kNumJoints; ++j) {
    const double amplitude_rad = j < 3 ? 0.25 : 0.8;
    for (int l = 0; l < harmonics; ++l) {
      // Position amplitude a / (w l) per harmonic: spread the joint's amplitude over the harmonics.
      const double scale = amplitude_rad * w * (l + 1) / harmonics;
      a[static_cast<std::size_t>(j)][static_cast<std::size_t>(l)] = scale * u(rng);
      b[static_cast<std::size_t>(j)][static_cast<std::size_t>(l)] = scale * u(rng);
    }
  }
  return trajectory::FourierTrajectory(paperStartPose(), f_base_hz, harmonics, 1.0 / f_base_hz, a, b);
}

std::vector<ContactSwitch> randomPushes(std::uint64_t seed, double t_begin_s, double t_end_s,
                                        const PushScenario& sc) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<ContactSwitch> pushes;
  double t = t_begin_s + sc.min_gap_s + (sc.max_gap_s - sc.min_gap_s) * u01(rng);
  for (;;) {
    const double duration = sc.min_duration_s + (sc.max_duration_s - sc.min_duration_s) * u01(rng);
    if (t + duration > t_end_s) break;
    Vec3 dir(n01(rng), n01(rng), n01(rng));
    while (dir.norm() < 1e-9) dir = Vec3(n01(rng), n01(rng), n01(rng));
    ContactSwitch push;
    push.enabled = true;
    push.t_start_s = t;
    push.t_end_s = t + duration;
    push.force_B = sc.force_N * dir.normalized();
    push.p_SP_S = Vec3(sc.tool_radius_m * (2.0 * u01(rng) - 1.0), sc.tool_radius_m * (2.0 * u01(rng) - 1.0),
                       0.02 + 0.13 * u01(rng));
    pushes.push_back(push);
    t += duration + sc.min_gap_s + (sc.max_gap_s - sc.min_gap_s) * u01(rng);
  }
  return pushes;
}

PayloadTruth compactObject(double mass_kg, const Vec3& p_SC_S, double side_m) {
  PayloadTruth p;
  p.mass_kg = mass_kg;
  p.p_SC_S = p_SC_S;
  p.I_C_S = Mat3::Identity() * (mass_kg * side_m * side_m / 6.0);
  return p;
}

}  // namespace ftid::sim
