// The compressed tilt search's data (gravity_compression.hpp; docs/identification.md).
#include "gravity_compression.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "concurrency.hpp"
#include "linear_algebra.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify::internal {

// From internal::kParallelRows samples the compressed tilt search's passes over the data run in
// two halves, the second on a thread of its own when it can (internal::runHalves).

bool GravityCompression::build(const Problem& pb, const Vec3& g_check_B) {
  const int n = pb.n;
  const int p = pb.p;
  p_ = p;
  // The probe samples: the affine check and the first guess of the non-zero columns.
  const int stride = std::max(1, n / 64);
  classifyEffects(pb, stride);
  Work main_work(p);
  // Non-zero entries of Y4 (column-major index 6 col + a), first from the probe samples; a full
  // pass that meets another one adds it and runs again (the union after a full pass is exact).
  const int entries = 6 * 4 * p;
  std::vector<char> used(static_cast<std::size_t>(entries), 0);
  if (!probeEntries(pb, g_check_B, stride, main_work, &used)) return false;
  // The data of the paper's static force stage (initialTilt): f0_a's column is 1 and the mass
  // column's E_k is s R_BS(k, a) in every sample (the gravity and offsets effects alone).
  const auto& index = pb.model.paramIndex();
  c_mass_ = index.column("mass");
  c_f0_[0] = index.column("f0_x");
  c_f0_[1] = index.column("f0_y");
  c_f0_[2] = index.column("f0_z");
  bool force_stage = c_mass_ >= 0 && c_f0_[0] >= 0 && c_f0_[1] >= 0 && c_f0_[2] >= 0;
  std::vector<char> found(static_cast<std::size_t>(entries), 0);  // left out but non-zero somewhere
  for (int pass = 0; pass < 2; ++pass) {
    layoutColumns(used, n);
    const Part sums = runPass(pb, pass, leftOutEntries(used), force_stage, main_work);
    for (int e = 0; e < entries; ++e) found[static_cast<std::size_t>(e)] |= sums.found[static_cast<std::size_t>(e)];
    force_stage = force_stage && sums.force_stage;
    if (sums.non_finite != 0.0) checkFinite(pb);  // throws, naming the first such sample
    bool complete = true;
    for (int e = 0; e < entries; ++e) {
      if (!used[static_cast<std::size_t>(e)] && found[static_cast<std::size_t>(e)]) {
        used[static_cast<std::size_t>(e)] = 1;
        complete = false;
      }
    }
    if (complete) break;
    if (pass == 1) return false;  // cannot happen: the first full pass found every column
  }
  force_stage_ = force_stage;
  return true;
}

void GravityCompression::classifyEffects(const Problem& pb, int stride) {
  const int n = pb.n;
  const int p = pb.p;
  // Effects whose contribution changes with g_S on a probe sample are evaluated four times per
  // sample (g_S = 0 and the three base axes), the others once. An effect with a constant gravity
  // slope (Effect::constantGravitySlope, e.g. gravity) is evaluated once, at g_S = 0, and its
  // slopes D_j (taken once) give E_k = sum_j s R_BS(k, j) D_j. A misclassified effect would show
  // in the affine check of the full regressor (build).
  fixed_effects_.clear();
  gravity_effects_.clear();
  slope_entry_.clear();
  slope_value_.clear();
  Eigen::Matrix<double, 6, Eigen::Dynamic> Z0(6, p), Zk(6, p);
  Eigen::Matrix<double, 6, Eigen::Dynamic> D[3];
  for (auto& Dj : D) Dj.setZero(6, p);
  SampleContext c;
  for (const auto& e : pb.model.effectList()) {
    bool reads_g = false;
    for (int i = 0; i < n && !reads_g; i += stride) {
      c = pb.at(i);
      c.wrench_model_S.setZero();
      c.g_S.setZero();
      Z0.setZero();
      e->addRegressor(c, Z0);
      for (int k = 0; k < 3 && !reads_g; ++k) {
        c.g_S = kStandardGravity * c.R_BS.row(k).transpose();
        Zk.setZero();
        e->addRegressor(c, Zk);
        reads_g = Zk != Z0;
      }
    }
    if (reads_g && e->constantGravitySlope()) {
      c = pb.at(0);
      c.wrench_model_S.setZero();
      c.g_S.setZero();
      Z0.setZero();
      e->addRegressor(c, Z0);
      for (int j = 0; j < 3; ++j) {
        c.g_S = Vec3::Unit(j);
        Zk.setZero();
        e->addRegressor(c, Zk);
        D[j] += Zk - Z0;
      }
      fixed_effects_.push_back(e.get());  // its g_S = 0 part
    } else {
      (reads_g ? gravity_effects_ : fixed_effects_).push_back(e.get());
    }
  }
  for (int e = 0; e < 6 * p; ++e) {
    const Vec3 d(D[0].data()[e], D[1].data()[e], D[2].data()[e]);
    if (d.isZero(0.0)) continue;
    slope_entry_.push_back(e);
    slope_value_.push_back(d);
  }
}

void GravityCompression::evaluate(const Problem& pb, int i, Work& wk) const {
  // Without effects evaluated at every gravity direction, the entries of E_k outside slope_entry_
  // stay zero (set once, by Work's constructor).
  const int p = p_;
  const bool general_gravity = !gravity_effects_.empty();
  const std::size_t n_slope = slope_entry_.size();
  SampleContext& c = wk.c;
  auto& Y4 = wk.Y4;
  auto& Yc = wk.Yc;
  c = pb.at(i);
  c.wrench_model_S.setZero();
  c.g_S.setZero();
  auto Y0 = Y4.leftCols(p);
  Y0.setZero();
  for (const auto* e : fixed_effects_) e->addRegressor(c, Y0);
  if (general_gravity) {
    Yc.setZero();
    for (const auto* e : gravity_effects_) e->addRegressor(c, Yc);
    Y0 += Yc;
  }
  for (int k = 0; k < 3; ++k) {
    auto Ek = Y4.middleCols((k + 1) * p, p);
    const Vec3 g_S = kStandardGravity * c.R_BS.row(k).transpose();  // R_BS^T (s e_k)
    double* ek = Ek.data();
    if (general_gravity) {
      c.g_S = g_S;
      Ek = -Yc;
      for (const auto* e : gravity_effects_) e->addRegressor(c, Ek);
      for (std::size_t q = 0; q < n_slope; ++q) ek[slope_entry_[q]] += g_S.dot(slope_value_[q]);
    } else {
      for (std::size_t q = 0; q < n_slope; ++q) ek[slope_entry_[q]] = g_S.dot(slope_value_[q]);
    }
  }
}

bool GravityCompression::affine(const Problem& pb, const Vec3& g_check_B, Work& wk) const {
  const int p = p_;
  SampleContext& c = wk.c;
  auto& Y4 = wk.Y4;
  auto& Yc = wk.Yc;
  c.g_S = c.R_BS.transpose() * g_check_B;
  pb.model.computeRegressor(c, Yc);
  Eigen::Matrix<double, 6, Eigen::Dynamic> comb = Y4.leftCols(p);
  for (int k = 0; k < 3; ++k) comb += (g_check_B(k) / kStandardGravity) * Y4.middleCols((k + 1) * p, p);
  const double scale = std::max(1.0, Yc.cwiseAbs().maxCoeff());
  return (Yc - comb).cwiseAbs().maxCoeff() <= 1e-9 * scale;
}

bool GravityCompression::probeEntries(const Problem& pb, const Vec3& g_check_B, int stride, Work& wk,
                                      std::vector<char>* used) const {
  const int entries = 6 * 4 * p_;
  for (int i = 0; i < pb.n; i += stride) {
    evaluate(pb, i, wk);
    if (!affine(pb, g_check_B, wk)) return false;
    for (int e = 0; e < entries; ++e) (*used)[static_cast<std::size_t>(e)] |= wk.Y4.data()[e] != 0.0 ? 1 : 0;
  }
  return true;
}

void GravityCompression::layoutColumns(const std::vector<char>& used, int n) {
  const int p = p_;
  const int m = 4 * p + 1;  // [A0 E0 E1 E2 y]
  // Column maps: B_a's columns are the used entries of axis a in the order (k, j), then y.
  for (int a = 0; a < 6; ++a) {
    std::vector<int>& map = col_[static_cast<std::size_t>(a)];
    std::vector<int>& src = src_[static_cast<std::size_t>(a)];
    map.assign(static_cast<std::size_t>(m), -1);
    src.clear();
    for (int col = 0; col < 4 * p; ++col) {
      if (used[static_cast<std::size_t>(6 * col + a)]) {
        map[static_cast<std::size_t>(col)] = static_cast<int>(src.size());
        src.push_back(6 * col + a);
      }
    }
    map[static_cast<std::size_t>(m - 1)] = static_cast<int>(src.size());
    b_cols_[static_cast<std::size_t>(a)] = static_cast<Eigen::Index>(src.size()) + 1;
  }
  // One block of scratch: B_0 .. B_5 (row-major, N x c_a each), then the scores (N x (p + 2)).
  n_ = n;
  std::size_t total = 0;
  for (int a = 0; a < 6; ++a) {
    b_offset_[static_cast<std::size_t>(a)] = total;
    total += static_cast<std::size_t>(n) * static_cast<std::size_t>(b_cols_[static_cast<std::size_t>(a)]);
  }
  s_offset_ = total;
  total += static_cast<std::size_t>(n) * static_cast<std::size_t>(p + 2);
  data_ = scratch_.reserve(total);
}

GravityCompression::LeftOut GravityCompression::leftOutEntries(const std::vector<char>& used) const {
  const int p = p_;
  const int entries = 6 * 4 * p;
  LeftOut lo;
  lo.left_out.resize(6, 4 * p);  // 1 for an entry left out of B_a
  for (int e = 0; e < entries; ++e) lo.left_out.data()[e] = used[static_cast<std::size_t>(e)] ? 0.0 : 1.0;
  for (int k = 0; k < 3; ++k) {  // entries of E_k from the slopes that are left out
    for (const int e : slope_entry_) {
      if (!used[static_cast<std::size_t>(6 * (k + 1) * p + e)]) lo.slope.push_back(6 * (k + 1) * p + e);
    }
  }
  return lo;
}

void GravityCompression::runRange(const Problem& pb, int pass, int begin, int end, const LeftOut& lo,
                                  bool force_stage, Work& wk, Part* part) {
  constexpr int kGramBlock = 256;
  const int p = p_;
  const int entries = 6 * 4 * p;
  const bool general_gravity = !gravity_effects_.empty();
  const auto& left_out = lo.left_out;
  for (int a = 0; a < 6; ++a) {
    const Eigen::Index ca = b_cols_[static_cast<std::size_t>(a)];
    part->G[static_cast<std::size_t>(a)].setZero(ca, ca);
  }
  part->found.assign(static_cast<std::size_t>(entries), 0);
  part->force_stage = force_stage;
  const auto& Y4w = wk.Y4;
  for (int i = begin; i < end; ++i) {
    evaluate(pb, i, wk);
    if (pass == 0) part->non_finite += nonFiniteProbe(pb.at(i));  // its cache lines were just read
    const double* y4 = Y4w.data();
    const Wrench& w = pb.at(i).wrench_S;
    for (int a = 0; a < 6; ++a) {
      const std::vector<int>& src = src_[static_cast<std::size_t>(a)];
      double* row = rowOf(a, i);  // one sample's row, contiguous
      const std::size_t ns = src.size();
      for (std::size_t j = 0; j < ns; ++j) row[j] = y4[src[j]];
      row[ns] = w(a);
    }
    // An entry left out must stay zero in every sample (a sum of |entries|: zero iff all are).
    // Without effects evaluated at every gravity direction, E_k is zero outside the slope
    // entries: Y0 and the slope entries left out suffice.
    bool any_left = false;
    if (general_gravity) {
      any_left = (Y4w.array().abs() * left_out).sum() != 0.0;
    } else {
      any_left = (Y4w.leftCols(p).array().abs() * left_out.leftCols(p)).sum() != 0.0;
      for (const int e : lo.slope) any_left = any_left || y4[e] != 0.0;
    }
    if (any_left) {
      for (int e = 0; e < entries; ++e) {
        part->found[static_cast<std::size_t>(e)] |= left_out.data()[e] != 0.0 && y4[e] != 0.0 ? 1 : 0;
      }
    }
    if (part->force_stage) {
      for (int a = 0; a < 3; ++a) {
        part->force_stage = part->force_stage && Y4w(a, c_f0_[a]) == 1.0;
        for (int k = 0; k < 3; ++k) {
          part->force_stage =
              part->force_stage && Y4w(a, (k + 1) * p + c_mass_) == kStandardGravity * wk.c.R_BS(k, a);
        }
      }
    }
    // The Gram matrices, a block of rows at a time while it is in the cache.
    if ((i + 1 - begin) % kGramBlock == 0 || i == end - 1) {
      const int i0 = i - (i - begin) % kGramBlock;
      for (int a = 0; a < 6; ++a) {
        part->G[static_cast<std::size_t>(a)].selfadjointView<Eigen::Lower>().rankUpdate(
            rowsOf(a).middleRows(i0, i - i0 + 1).transpose());
      }
    }
  }
}

GravityCompression::Part GravityCompression::runPass(const Problem& pb, int pass, const LeftOut& lo,
                                                     bool force_stage, Work& main_work) {
  const int n = pb.n;
  const int entries = 6 * 4 * p_;
  // Two ranges from internal::kParallelRows on (a split that depends on n alone, so the sums and the
  // result do not depend on the machine), the second on a thread of its own where there is a
  // second core; their Gram matrices added in range order.
  std::array<Part, 2> parts;
  const int mid = n >= internal::kParallelRows ? n / 2 : n;
  if (mid < n) {
    Work second_work(p_);
    internal::runHalves([&] { runRange(pb, pass, 0, mid, lo, force_stage, main_work, &parts[0]); },
                        [&] { runRange(pb, pass, mid, n, lo, force_stage, second_work, &parts[1]); });
  } else {
    runRange(pb, pass, 0, n, lo, force_stage, main_work, &parts[0]);
  }
  Part sums;
  sums.found.assign(static_cast<std::size_t>(entries), 0);
  sums.force_stage = true;
  for (int q = 0; q < (mid < n ? 2 : 1); ++q) {
    const Part& part = parts[static_cast<std::size_t>(q)];
    for (int a = 0; a < 6; ++a) {
      if (q == 0) {
        G_[static_cast<std::size_t>(a)] = part.G[static_cast<std::size_t>(a)];
      } else {
        G_[static_cast<std::size_t>(a)] += part.G[static_cast<std::size_t>(a)];
      }
    }
    for (int e = 0; e < entries; ++e) sums.found[static_cast<std::size_t>(e)] |= part.found[static_cast<std::size_t>(e)];
    sums.non_finite += part.non_finite;
    sums.force_stage = sums.force_stage && part.force_stage;
  }
  return sums;
}

void GravityCompression::factor(bool gram) {
  gram_ = gram;
  rows_ = 0;
  for (int a = 0; a < 6; ++a) {
    const auto Ba = rowsOf(a);
    Eigen::MatrixXd& Ra = R_[static_cast<std::size_t>(a)];
    if (gram) {
      const Eigen::Index ca = Ba.cols();
      Eigen::MatrixXd G = G_[static_cast<std::size_t>(a)];  // lower triangle, accumulated in build()
      G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
      Eigen::VectorXd d(ca);  // column scaling
      for (Eigen::Index j = 0; j < ca; ++j) d(j) = G(j, j) > 0.0 ? std::sqrt(G(j, j)) : 1.0;
      const Eigen::MatrixXd Gs = d.cwiseInverse().asDiagonal() * G * d.cwiseInverse().asDiagonal();
      // The regressor columns (y, the last, apart): pivoted LDLT, semidefinite allowed,
      // Gs_AA = P^T L D L^T P, so R_AA = sqrt(D) L^T P (Eigen's transpositionsP() from the right
      // is P^T). Then R_AA^T r_Ay = Gs_Ay and rho^2 = Gs_yy - |r_Ay|^2: the part of y outside
      // every column is the last pivot, a constant of the cost whatever its rounding, and the
      // tilt search's cost and steps depend only on the well-conditioned rest.
      const Eigen::Index cr = ca - 1;
      if (cr == 0) {  // no regressor column on this axis
        Ra = Eigen::MatrixXd::Constant(1, 1, std::sqrt(G(0, 0)));
        offset_[static_cast<std::size_t>(a)] = rows_;
        rows_ += 1;
        continue;
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(Gs.topLeftCorner(cr, cr));
      const Eigen::VectorXd sd = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
      Ra = Eigen::MatrixXd::Zero(ca, ca);
      Ra.topLeftCorner(cr, cr) = sd.asDiagonal() * Eigen::MatrixXd(ldlt.matrixU());
      Ra.topLeftCorner(cr, cr) = Ra.topLeftCorner(cr, cr) * ldlt.transpositionsP().transpose();
      Eigen::VectorXd x = ldlt.transpositionsP() * Gs.col(cr).head(cr);
      ldlt.matrixL().solveInPlace(x);
      for (Eigen::Index j = 0; j < cr; ++j) x(j) = sd(j) > 0.0 ? x(j) / sd(j) : 0.0;
      Ra.col(cr).head(cr) = x;
      Ra(cr, cr) = std::sqrt(std::max(0.0, Gs(cr, cr) - x.squaredNorm()));
      Ra = Ra * d.asDiagonal();
    } else {
      Eigen::MatrixXd D = Ba;  // thinR factors in place; B_a stays for the per-sample rows
      Ra = internal::thinR(D);
    }
    offset_[static_cast<std::size_t>(a)] = rows_;
    rows_ += Ra.rows();
  }
  // Stacked column blocks P_k (rows x p): P_k's column j is R_a's column of (k, j) (zero if absent).
  for (auto& P : P_) P = Eigen::MatrixXd::Zero(rows_, p_);
  Py_ = Eigen::VectorXd::Zero(rows_);
  axis_of_row_.resize(rows_);
  for (int a = 0; a < 6; ++a) {
    const auto& Ra = R_[static_cast<std::size_t>(a)];
    const Eigen::Index o = offset_[static_cast<std::size_t>(a)];
    const Eigen::Index ra = Ra.rows();
    axis_of_row_.segment(o, ra).setConstant(a);
    for (int k = 0; k < 4; ++k) {
      for (int j = 0; j < p_; ++j) {
        const int bc = col_[static_cast<std::size_t>(a)][static_cast<std::size_t>(k * p_ + j)];
        if (bc >= 0) P_[static_cast<std::size_t>(k)].block(o, j, ra, 1) = Ra.col(bc);
      }
    }
    Py_.segment(o, ra) = Ra.col(col_[static_cast<std::size_t>(a)][static_cast<std::size_t>(4 * p_)]);
  }
}

bool GravityCompression::initialTilt(double rank_tolerance, double* tilt_u_rad, double* tilt_v_rad) const {
  if (!force_stage_) return false;
  Eigen::Index rows = 0;
  for (int a = 0; a < 3; ++a) rows += R_[static_cast<std::size_t>(a)].rows();
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(rows, 6);  // unknowns [L, F0]
  Eigen::VectorXd z(rows);
  for (int a = 0, o = 0; a < 3; ++a) {
    const auto& map = col_[static_cast<std::size_t>(a)];
    const auto& Ra = R_[static_cast<std::size_t>(a)];
    const Eigen::Index ra = Ra.rows();
    for (int k = 0; k < 3; ++k) {
      const int bc = map[static_cast<std::size_t>((k + 1) * p_ + c_mass_)];
      if (bc < 0) return false;  // R_BS(k, a) = 0 in every sample: not determined
      K.block(o, k, ra, 1) = Ra.col(bc) / kStandardGravity;
    }
    const int bf = map[static_cast<std::size_t>(c_f0_[a])];
    if (bf < 0) return false;
    K.block(o, 3 + a, ra, 1) = Ra.col(bf);
    z.segment(o, ra) = Ra.col(map[static_cast<std::size_t>(4 * p_)]);
    o += static_cast<int>(ra);
  }
  const internal::ScaledQR qr(K, rank_tolerance);
  if (qr.rank().rank < 6 || (gram_ && qr.rank().condition_number > kGramConditionLimit)) return false;
  const Eigen::VectorXd l = qr.solve(z);
  double weight_N = 0.0;
  gravityToWeightAndTilt(l.head<3>(), &weight_N, tilt_u_rad, tilt_v_rad);
  return true;
}

void GravityCompression::compressed(const Vec3& g_B, const Vec6& w, Eigen::MatrixXd* C, Eigen::VectorXd* z) const {
  *C = P_[0];
  for (int k = 0; k < 3; ++k) *C += (g_B(k) / kStandardGravity) * P_[static_cast<std::size_t>(k + 1)];
  *z = Py_;
  for (Eigen::Index r = 0; r < rows_; ++r) {
    const double wa = w(axis_of_row_(r));
    C->row(r) *= wa;
    (*z)(r) *= wa;
  }
}

LinearSolution GravityCompression::solve(const NonlinearParams& nl, const Vec6& w) const {
  Eigen::MatrixXd C;
  Eigen::VectorXd z;
  compressed(model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad), w, &C, &z);
  return solveLinear(C, z);
}

Eigen::MatrixXd GravityCompression::jacobianMix(int a, const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                                const Eigen::VectorXd& theta) const {
  const auto& map = col_[static_cast<std::size_t>(a)];
  const int ca = static_cast<int>(b_cols_[static_cast<std::size_t>(a)]);
  Eigen::MatrixXd mix = Eigen::MatrixXd::Zero(ca, p_ + 2);
  for (int j = 0; j < p_; ++j) {
    const int c0 = map[static_cast<std::size_t>(j)];
    if (c0 >= 0) mix(c0, j) += 1.0;
    for (int k = 0; k < 3; ++k) {
      const int ck = map[static_cast<std::size_t>((k + 1) * p_ + j)];
      if (ck < 0) continue;
      mix(ck, j) += g_B(k) / kStandardGravity;
      mix(ck, p_) += dg_u(k) / kStandardGravity * theta(j);
      mix(ck, p_ + 1) += dg_v(k) / kStandardGravity * theta(j);
    }
  }
  return mix;
}

Eigen::MatrixXd GravityCompression::compressedJacobian(const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                                       const Eigen::VectorXd& theta, const Vec6& w) const {
  Eigen::MatrixXd J(rows_, p_ + 2);
  for (int a = 0; a < 6; ++a) {
    const auto& Ra = R_[static_cast<std::size_t>(a)];
    J.middleRows(offset_[static_cast<std::size_t>(a)], Ra.rows()) = w(a) * Ra * jacobianMix(a, g_B, dg_u, dg_v, theta);
  }
  return J;
}

Vec6 GravityCompression::residualSquares(const Vec3& g_B, const Eigen::VectorXd& theta) const {
  Vec6 ss;
  for (int a = 0; a < 6; ++a) ss(a) = (R_[static_cast<std::size_t>(a)] * residualMix(a, g_B, theta)).squaredNorm();
  return ss;
}

Eigen::Map<const Eigen::MatrixXd> GravityCompression::scores(const Vec3& g_B, const Vec3& dg_u,
                                                             const Vec3& dg_v, const Eigen::VectorXd& theta,
                                                             const Vec6& w, Mat6X* residual_unweighted) {
  const Eigen::Index n = n_;
  const Eigen::Index k = p_ + 2;
  Eigen::Map<Eigen::MatrixXd> S(data_ + s_offset_, n, k);
  residual_unweighted->resize(6, n);
  std::array<Eigen::Matrix<double, Eigen::Dynamic, 3>, 6> dots;  // columns v_a, mix_a(:, p), mix_a(:, p + 1)
  struct Feed {
    Eigen::Index to;     ///< score column j < p
    Eigen::Index first;  ///< its terms in from/weight
    Eigen::Index count;
  };
  std::array<std::vector<Feed>, 6> feeds;
  std::array<std::vector<Eigen::Index>, 6> from;  // columns of B_a, grouped by the score column they feed
  std::array<std::vector<double>, 6> weight;      // their mix_a entries
  for (int a = 0; a < 6; ++a) {
    const std::size_t ua = static_cast<std::size_t>(a);
    const Eigen::MatrixXd mix = jacobianMix(a, g_B, dg_u, dg_v, theta);
    const Eigen::Index ca = mix.rows();
    dots[ua].resize(ca, 3);
    dots[ua].col(0) = residualMix(a, g_B, theta);
    dots[ua].col(1) = mix.col(p_);
    dots[ua].col(2) = mix.col(p_ + 1);
    for (Eigen::Index j = 0; j < p_; ++j) {
      const Eigen::Index first = static_cast<Eigen::Index>(from[ua].size());
      for (Eigen::Index bc = 0; bc < ca; ++bc) {
        if (mix(bc, j) == 0.0) continue;
        from[ua].push_back(bc);
        weight[ua].push_back(mix(bc, j));
      }
      const Eigen::Index count = static_cast<Eigen::Index>(from[ua].size()) - first;
      if (count > 0) feeds[ua].push_back({j, first, count});
    }
  }
  // Blocks of rows (scores row-major: a sample's k entries together, copied into S's columns);
  // from internal::kParallelRows on the second half of the blocks on a thread of its own (rows of S
  // and of the residual are the samples': the halves write apart).
  constexpr Eigen::Index kBlock = 256;
  auto runBlocks = [&](Eigen::Index begin, Eigen::Index end) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> T(kBlock, k);
    for (Eigen::Index i0 = begin; i0 < end; i0 += kBlock) {
      const Eigen::Index len = std::min(kBlock, end - i0);
      T.topRows(len).setZero();
      for (int a = 0; a < 6; ++a) {
        const std::size_t ua = static_cast<std::size_t>(a);
        const Eigen::Index ca = b_cols_[ua];
        const double* v = dots[ua].col(0).data();
        const double* mu = dots[ua].col(1).data();
        const double* mv = dots[ua].col(2).data();
        const std::vector<Feed>& fa = feeds[ua];
        const Eigen::Index* f = from[ua].data();
        const double* m = weight[ua].data();
        const double w2 = w(a) * w(a);
        const double* row = rowOf(a, i0);
        for (Eigen::Index i = 0; i < len; ++i, row += ca) {
          double r = 0.0, du = 0.0, dv = 0.0;
          for (Eigen::Index c = 0; c < ca; ++c) {
            r += row[c] * v[c];
            du += row[c] * mu[c];
            dv += row[c] * mv[c];
          }
          (*residual_unweighted)(a, i0 + i) = r;
          const double q = w2 * r;
          double* t = T.data() + i * k;
          t[p_] += q * du;
          t[p_ + 1] += q * dv;
          for (const Feed& feed : fa) {
            double sum = 0.0;
            for (Eigen::Index e = feed.first; e < feed.first + feed.count; ++e) sum += m[e] * row[f[e]];
            t[feed.to] += q * sum;
          }
        }
      }
      S.middleRows(i0, len) = T.topRows(len);
    }
  };
  const Eigen::Index mid = n >= internal::kParallelRows ? ((n / 2 + kBlock - 1) / kBlock) * kBlock : n;
  if (mid < n) {
    internal::runHalves([&] { runBlocks(0, mid); }, [&] { runBlocks(mid, n); });
  } else {
    runBlocks(0, n);
  }
  return {S.data(), n, k};
}

Eigen::VectorXd GravityCompression::residualMix(int a, const Vec3& g_B, const Eigen::VectorXd& theta) const {
  const auto& map = col_[static_cast<std::size_t>(a)];
  Eigen::VectorXd v = Eigen::VectorXd::Zero(b_cols_[static_cast<std::size_t>(a)]);
  v(map[static_cast<std::size_t>(4 * p_)]) = 1.0;
  for (int j = 0; j < p_; ++j) {
    const int c0 = map[static_cast<std::size_t>(j)];
    if (c0 >= 0) v(c0) -= theta(j);
    for (int k = 0; k < 3; ++k) {
      const int ck = map[static_cast<std::size_t>((k + 1) * p_ + j)];
      if (ck >= 0) v(ck) -= g_B(k) / kStandardGravity * theta(j);
    }
  }
  return v;
}

}  // namespace ftid::identify::internal
