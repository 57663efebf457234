#pragma once
// Statistical claims tested as claims (issue 11): an estimator that prints "value +- std" claims
// that over independent noise draws its estimates scatter by `std` around the truth. A seed study
// checks that claim directly: one clean simulated run, many seeded noise draws, the estimator on
// each, then per parameter
//   spread   = sample standard deviation of the estimates over the seeds,
//   reported = RMS of the standard errors the estimator printed,
//   ratio    = spread / reported          (claim: 1 within +-tol; default tol 0.3),
//   bias_z   = (mean - truth) / (spread / sqrt(seeds))   (claim: |bias_z| < 4).
// With n seeds the ratio itself scatters by about 1/sqrt(2(n-1)) (0.1 at n = 50, 0.05 at 200).
//
// Built to be extended: a case is {clean contexts, noise model, estimator, parameters}. Coloured
// noise, static pose sets or a HAC estimator are a new NoiseModel / Estimator, not a new test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace ftid::stats_test {

using effects::SampleContext;

struct Estimate {
  double value = 0.0;
  double std = 0.0;
};
/// Parameter name (docs/conventions.md) -> estimate with its reported standard error.
using Estimates = std::map<std::string, Estimate>;
using Estimator = std::function<Estimates(const std::vector<SampleContext>&)>;
/// Adds one noise draw to the readings of clean contexts (in place).
using NoiseModel = std::function<void(std::vector<SampleContext>&, std::mt19937_64&)>;

/// The simulator's own white noise (CellSim::addNoise: Gaussian, per axis wrench_std), applied to
/// the wrench readings of contexts built from a noise-free run of the same simulator. Re-running
/// the whole simulation per seed would give the same readings at many times the cost.
inline NoiseModel simulatorWhiteNoise(const sim::CellSimConfig& config) {
  auto simulator = std::make_shared<sim::CellSim>(config);
  return [simulator](std::vector<SampleContext>& ctx, std::mt19937_64& rng) {
    for (auto& c : ctx) {
      sim::SensorReading r;
      r.wrench_S = c.wrench_S;
      simulator->addNoise(r, rng);
      c.wrench_S = r.wrench_S;
    }
  };
}

/// The simulator's own wrench noise of any kind (white, low-pass filtered, oversampled; on a time
/// series or a static pose set; sim::NoiseConfig): each draw re-runs the simulator with a seed
/// taken from rng and adds the difference of its wrench readings from those of the same run
/// without noise (the noise is additive, so the result is exactly that run's readings). The
/// config must have no IMU or temperature noise and no glitches (they would not be carried over).
inline NoiseModel simulatorNoise(const sim::CellSimConfig& config) {
  if (config.noise.acc_std != 0.0 || config.noise.gyro_std != 0.0 || config.noise.alpha_std != 0.0 ||
      config.noise.temp_std != 0.0 || config.glitches.enabled) {
    throw std::invalid_argument("simulatorNoise: only wrench noise is carried over");
  }
  sim::CellSimConfig clean_config = config;
  clean_config.noise = sim::NoiseConfig{};
  auto clean = std::make_shared<const logio::LogData>(sim::CellSim(clean_config).run());
  return [config, clean](std::vector<SampleContext>& ctx, std::mt19937_64& rng) {
    sim::CellSimConfig c = config;
    c.seed = rng();
    const logio::LogData noisy = sim::CellSim(c).run();
    if (noisy.samples.size() != ctx.size() || clean->samples.size() != ctx.size()) {
      throw std::invalid_argument("simulatorNoise: the contexts are not those of this simulator run");
    }
    for (std::size_t i = 0; i < ctx.size(); ++i) {
      ctx[i].wrench_S += noisy.samples[i].wrench_S - clean->samples[i].wrench_S;
    }
  };
}

/// Coloured (AR(1)) noise on the wrench readings, added to whatever is there: per axis
/// x_k = phi x_{k-1} + sqrt(1 - phi^2) std_axis e_k, stationary std std_axis, correlation time
/// -1 / ln(phi) samples. White noise is phi = 0.
inline NoiseModel ar1WrenchNoise(const Vec6& std_axis, double phi) {
  return [std_axis, phi](std::vector<SampleContext>& ctx, std::mt19937_64& rng) {
    std::normal_distribution<double> n01(0.0, 1.0);
    const double innovation = std::sqrt(1.0 - phi * phi);
    Vec6 x;
    for (int a = 0; a < 6; ++a) x(a) = std_axis(a) * n01(rng);
    for (auto& c : ctx) {
      for (int a = 0; a < 6; ++a) x(a) = phi * x(a) + innovation * std_axis(a) * n01(rng);
      c.wrench_S += x;
    }
  };
}

/// Several noise models applied in turn (e.g. white sensor noise plus a coloured part).
inline NoiseModel both(NoiseModel first, NoiseModel second) {
  return [first, second](std::vector<SampleContext>& ctx, std::mt19937_64& rng) {
    first(ctx, rng);
    second(ctx, rng);
  };
}

struct Series {
  std::vector<double> values;
  std::vector<double> stds;
};

struct StudyResult {
  int seeds = 0;
  std::map<std::string, Series> params;
};

/// Runs the estimator on `seeds` noise draws (seeds first_seed, first_seed + 1, ...).
inline StudyResult runSeedStudy(const std::vector<SampleContext>& clean, const NoiseModel& noise,
                                const Estimator& estimator, int seeds, std::uint64_t first_seed) {
  StudyResult out;
  out.seeds = seeds;
  std::vector<SampleContext> ctx;
  for (int k = 0; k < seeds; ++k) {
    ctx = clean;
    std::mt19937_64 rng(first_seed + static_cast<std::uint64_t>(k));
    noise(ctx, rng);
    for (const auto& [name, e] : estimator(ctx)) {
      out.params[name].values.push_back(e.value);
      out.params[name].stds.push_back(e.std);
    }
  }
  return out;
}

struct SpreadCheck {
  int n = 0;
  double mean = 0.0;
  double spread = 0.0;    ///< sample std of the estimates
  double reported = 0.0;  ///< RMS of the reported standard errors (times std_scale)
  double ratio = 0.0;     ///< spread / reported
  double bias_z = 0.0;    ///< (mean - truth) / (spread / sqrt(n))
  std::string describe() const {
    std::ostringstream s;
    s << "n=" << n << " mean=" << mean << " spread=" << spread << " reported=" << reported
      << " ratio=" << ratio << " bias_z=" << bias_z;
    return s.str();
  }
};

/// `std_scale` multiplies every reported standard error (to show what the check rejects).
inline SpreadCheck checkSpread(const Series& s, double truth, double std_scale = 1.0) {
  SpreadCheck c;
  c.n = static_cast<int>(s.values.size());
  if (c.n < 2) return c;
  for (double v : s.values) c.mean += v / c.n;
  double var = 0.0, rep2 = 0.0;
  for (double v : s.values) var += (v - c.mean) * (v - c.mean) / (c.n - 1);
  for (double e : s.stds) rep2 += (std_scale * e) * (std_scale * e) / c.n;
  c.spread = std::sqrt(var);
  c.reported = std::sqrt(rep2);
  c.ratio = c.reported > 0.0 ? c.spread / c.reported : 0.0;
  c.bias_z = c.spread > 0.0 ? (c.mean - truth) / (c.spread / std::sqrt(static_cast<double>(c.n))) : 0.0;
  return c;
}

inline bool claimHolds(const SpreadCheck& c, double tol) {
  return c.ratio >= 1.0 - tol && c.ratio <= 1.0 + tol && std::abs(c.bias_z) < 4.0;
}

/// The claim for one parameter, plus the check's power: the same data must reject standard errors
/// reported 1.7x too large or 1.7x too small.
inline void expectClaim(const StudyResult& study, const std::string& name, double truth, double tol = 0.3) {
  SCOPED_TRACE(name);
  const auto it = study.params.find(name);
  ASSERT_NE(it, study.params.end()) << "the estimator reported no '" << name << "'";
  ASSERT_EQ(static_cast<int>(it->second.values.size()), study.seeds);
  const SpreadCheck c = checkSpread(it->second, truth);
  std::printf("  %-8s %s\n", name.c_str(), c.describe().c_str());
  EXPECT_GT(c.reported, 0.0) << c.describe();
  EXPECT_GE(c.ratio, 1.0 - tol) << "the estimates scatter less than the reported std: " << c.describe();
  EXPECT_LE(c.ratio, 1.0 + tol) << "the estimates scatter more than the reported std: " << c.describe();
  EXPECT_LT(std::abs(c.bias_z), 4.0) << "biased: " << c.describe();
  EXPECT_FALSE(claimHolds(checkSpread(it->second, truth, 1.7), tol)) << "cannot tell 1.7x too large: " << c.describe();
  EXPECT_FALSE(claimHolds(checkSpread(it->second, truth, 1.0 / 1.7), tol))
      << "cannot tell 1.7x too small: " << c.describe();
}

}  // namespace ftid::stats_test
