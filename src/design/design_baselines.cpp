// The designer's baselines (design_stages.hpp): what a designed trajectory is compared with.
//   - random: the median column-scaled condition number of `baseline_seeds` random Fourier
//     trajectories of the same duration and harmonics, each scaled into the feasible set (seeds
//     derived from DesignOptions::seed, so the median is reproducible);
//   - static six-pose: wrist offsets (joints 4-6) from q0 in eighth turns, each feasible pose
//     scored by how closely gravity in the sensor frame, R_BS^T (0, 0, -1), points along one of
//     +-x, +-y, +-z of S (cosine above 0.7, small moves preferred); with all six directions found,
//     the information of the six poses at rest, each weighted by a sixth of the represented samples.
#include <algorithm>
#include <cmath>

#include "design_stages.hpp"

namespace ftid::design::internal {

namespace {

/// Median condition number of random feasible trajectories into b.
void randomBaseline(const DesignOptions& opt, Problem& p, BaselineReport& b) {
  // Random feasible Fourier trajectories of the same duration and harmonics.
  std::vector<double> conds;
  for (int i = 0; i < opt.baseline_seeds; ++i) {
    std::mt19937_64 rng(opt.seed * 1000003ULL + 7919ULL * static_cast<std::uint64_t>(i) + 17ULL);
    const std::vector<double> x = p.makeFeasible(randomDirection(rng, p.n()));
    conds.push_back(ExcitationMetric::conditionNumber(p.information(x)));
  }
  if (!conds.empty()) {
    std::sort(conds.begin(), conds.end());
    const std::size_t h = conds.size() / 2;
    b.random_median_condition = conds.size() % 2 ? conds[h] : 0.5 * (conds[h - 1] + conds[h]);
    b.random_count = static_cast<int>(conds.size());
  }
}

}  // namespace

BaselineReport computeBaselines(const DesignOptions& opt, Problem& p,
                                const model::RobotKinematics& kin) {
  BaselineReport b;
  randomBaseline(opt, p, b);
  if (!opt.static_baseline) return b;
  // Static six-pose method: wrist (joints 4-6) offsets from q0 in eighth turns, feasible poses,
  // one pose per gravity direction +-x, +-y, +-z in S (the closest feasible one).
  model::RobotKinematics k = kin;
  k.setSensorMount(opt.constraints.R_FS, opt.constraints.p_FS_F);
  const auto& c = opt.constraints;
  const double step = 0.7853981633974483;
  Vec3 dirs[6] = {Vec3::UnitX(),  -Vec3::UnitX(), Vec3::UnitY(),
                  -Vec3::UnitY(), Vec3::UnitZ(),  -Vec3::UnitZ()};
  double best_score[6] = {-2, -2, -2, -2, -2, -2};
  JointVector best_pose[6];
  for (int a = -4; a <= 4; ++a) {
    for (int bb = -4; bb <= 4; ++bb) {
      for (int cc = -4; cc <= 4; ++cc) {
        JointVector q = opt.q0;
        q[3] += a * step;
        q[4] += bb * step;
        q[5] += cc * step;
        if (((q - c.position_lower).array() < 0.0).any() ||
            ((c.position_upper - q).array() < 0.0).any())
          continue;
        const auto sm = k.computeSensorMotion(q, JointVector::Zero(), JointVector::Zero());
        bool ok = true;
        for (const auto& tool : c.tool) {
          const Vec3 p_B = sm.p_BS_B + sm.R_BS * tool.center_S;
          if (p_B.z() - tool.radius < c.floor_z_B) ok = false;
          for (const auto& ko : c.keep_out) {
            if ((p_B - ko.center_B).norm() < ko.radius + tool.radius) ok = false;
          }
        }
        if (!ok) continue;
        const Vec3 g_dir = (sm.R_BS.transpose() * Vec3(0.0, 0.0, -1.0));
        // prefer small moves: tiny penalty on the offset size
        const double cost = 1e-3 * (std::abs(a) + std::abs(bb) + std::abs(cc));
        for (int d = 0; d < 6; ++d) {
          const double score = g_dir.dot(dirs[d]) - cost;
          if (score > best_score[d]) {
            best_score[d] = score;
            best_pose[d] = q;
          }
        }
      }
    }
  }
  std::vector<JointVector> qs, zeros;
  for (int d = 0; d < 6; ++d) {
    if (best_score[d] > 0.7) qs.push_back(best_pose[d]);
  }
  b.static_poses = qs;
  if (qs.size() == 6) {
    zeros.assign(qs.size(), JointVector::Zero());
    const Eigen::MatrixXd info = p.metric().information(qs, zeros, zeros, p.represented() / 6.0);
    b.static_condition = ExcitationMetric::conditionNumber(info);
    b.static_std = p.metric().predictedStd(info);
  }
  return b;
}

}  // namespace ftid::design::internal
