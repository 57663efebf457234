#pragma once
// The compressed tilt search's data (private to ftid_identify; FitOptions::compressed_tilt_search,
// docs/identification.md). What it computes, and what it must equal, is the identity below: the
// general path's weighted cost, projected residual norm, Jacobian Gram matrix and per-sample
// residual and scores (fit_problem.hpp, Problem::buildRegressor / predict), from per-axis factors
// of size independent of N. test/unit/identify (CompressedTilt.*) checks the two paths against
// each other.
#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Dense>

#include "fit_problem.hpp"
#include "thread_scratch.hpp"
#include "ftid/common/types.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::identify::internal {

/// The compressed tilt search (FitOptions::compressed_tilt_search; docs/identification.md).
///
/// For a model whose only nonlinear parameters are the tilt (no mounting, delay or effects that
/// read the modelled wrench), the tilt enters only through g_S = R_BS^T g_B and the regressor is
/// affine in g_S (checked on a sample of the data; e.g. harmonic(gx,1) is not, and then the general
/// path runs). So per axis a, with s = standard gravity and e_k the base axes,
///
///   A_a(g_B) = A0_a + sum_k (g_B(k) / s) E_k,a      A0_a = A_a(g_S = 0), E_k,a = A_a(s R_BS^T e_k) - A0_a
///
/// is a fixed combination M_a(g_B) of the columns of B_a = [A0_a E_0,a E_1,a E_2,a y_a] (N x c_a,
/// columns that are zero in every sample left out). Any c_a x c_a factor R_a with
/// R_a^T R_a = B_a^T B_a (the Gram matrix) gives, for the per-axis weights w_a,
///
///   sum_i |W (w_i - Y_i(g_B) theta)|^2 = sum_a w_a^2 |R_a (e_y - M_a(g_B) theta)|^2
///
/// exactly, so every solve of the variable projection is a QR of the stacked [w_a R_a M_a(g_B)]
/// (sum_a c_a rows, p columns), independent of N, with the same Gauss-Newton steps. The same holds
/// for the joint Jacobian [A(g_B), dA/dU theta, dA/dV theta] (its rank, condition number and
/// (J^T J)^{-1}); only the Newey-West scores and the per-sample residual need the rows, one pass
/// over B_a. R_a comes from the Gram matrix accumulated in one pass (pivoted LDLT of the
/// column-scaled Gram of the regressor columns, the measurement column last) when the problem is
/// well conditioned (rounding error ~ cond^2 eps, kGramConditionLimit: checked on the regressor at
/// the start and on the final joint Jacobian), else from the thin Householder QR B_a = Q_a R_a
/// (internal::thinR, rounding ~ cond eps).
class GravityCompression {
 public:
  /// Evaluates B_a for every sample; false if the regressor is not affine in g_S (checked at
  /// g_check_B on the probe samples). Its pass over the data also runs checkFinite's test (throws
  /// DataError naming the first non-finite sample); after false, the caller runs checkFinite.
  bool build(const Problem& pb, const Vec3& g_check_B);

  /// Factors every B_a (R_a^T R_a = B_a^T B_a): from the Gram matrix (gram) or by Householder QR.
  void factor(bool gram);
  bool gram() const { return gram_; }

  /// The fit's start (U, V): the paper's static force stage f_i = R_BS,i^T L + F0 (the same as
  /// initialTilt(), paper_method.cpp) solved on the compressed force axes, whose columns hold its
  /// data exactly. False (u, v untouched) if the model lacks those columns, the force stage is not
  /// determined, or (Gram factor) too ill-conditioned for it: then initialTilt() decides.
  bool initialTilt(double rank_tolerance, double* tilt_u_rad, double* tilt_v_rad) const;

  /// Weighted compressed regressor [w_a R_a M_a(g_B)] (rows() x p) and measurement.
  void compressed(const Vec3& g_B, const Vec6& w, Eigen::MatrixXd* C, Eigen::VectorXd* z) const;

  /// The projected residual (compressed: R_a (e_y - M_a theta) per axis) and theta for the tilt in nl.
  LinearSolution solve(const NonlinearParams& nl, const Vec6& w) const;

  /// Mixing matrices of the joint Jacobian of axis a: B_a * mix = [A_a(g_B), dA_a theta(dg_u), dA_a theta(dg_v)]
  /// (unweighted), and the measurement's column e_y. dg_u, dg_v are the derivatives of g_B.
  Eigen::MatrixXd jacobianMix(int a, const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                              const Eigen::VectorXd& theta) const;

  /// Weighted joint Jacobian, compressed (rows() x (p + 2)): same column norms, singular values and
  /// (J^T J)^{-1} as the stacked one.
  Eigen::MatrixXd compressedJacobian(const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                     const Eigen::VectorXd& theta, const Vec6& w) const;

  /// Per-axis sums of squares of the unweighted residual w_i - Y_i(g_B) theta over the samples,
  /// |B_a v|^2 = |R_a v|^2 (R_a^T R_a = B_a^T B_a): no pass over the rows. The Gram factor holds
  /// y_a's part outside the columns to the rounding of the Gram sums (blocks of 256 rows, then the
  /// blocks in turn: ~(256 + N/256) eps |y_a|^2, about 1e-14 |y_a|^2 at 10,001 samples), so a sum
  /// is exact to that relative to itself (1e-8 at a signal-to-noise power ratio of 1e6): ample for
  /// the axis weights it sets (the fit's residual, sigma^2 and scores come from the rows).
  Vec6 residualSquares(const Vec3& g_B, const Eigen::VectorXd& theta) const;

  /// Newey-West scores (N x (p + 2), row i = sum_a J_(6i+a)^T r_(6i+a) of the weighted joint
  /// Jacobian and residual) and the unweighted residual (6 x N), in one pass over the rows of B_a:
  /// the Jacobian rows of axis a are w_a B_a(i, :) mix_a, so s_i = sum_a w_a^2 r_a(i) B_a(i, :) mix_a
  /// with r_a(i) = B_a(i, :) v_a. mix_a is sparse: column bc of B_a (A0 or E_k of theta_j) feeds
  /// score column j with weight 1 or g_B(k) / s, and the two tilt columns through the dense
  /// vectors mix_a(:, p) and mix_a(:, p + 1). So a row costs three dot products of length c_a and
  /// one product per score column it feeds (the columns of B_a feeding theta_j summed first: a
  /// store per score column, no chain of stores to one column).
  /// The scores live in this object's scratch (valid while it lives, until the next call).
  Eigen::Map<const Eigen::MatrixXd> scores(const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                           const Eigen::VectorXd& theta, const Vec6& w,
                                           Mat6X* residual_unweighted);

  Eigen::Index rows() const { return rows_; }

 private:
  // The steps of build() (gravity_compression.cpp), in the order it runs them.

  /// One sample's Y4 = [Y0 E0 E1 E2] (6 x 4p) and the scratch of its evaluation; one per thread
  /// of the pass (the effects are const and keep no state).
  struct Work {
    SampleContext c;
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y4;
    Eigen::Matrix<double, 6, Eigen::Dynamic> Yc;
    explicit Work(int p_cols) : Y4(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, 4 * p_cols)), Yc(6, p_cols) {}
  };
  /// The entries of Y4 left out of B_a (1 in left_out), and those of them that the gravity slopes
  /// would set (E_k's slope entries).
  struct LeftOut {
    Eigen::Array<double, 6, Eigen::Dynamic> left_out;
    std::vector<int> slope;
  };
  /// What a range of samples contributes to a pass (the pass runs in two ranges, see runPass).
  struct Part {
    std::array<Eigen::MatrixXd, 6> G;  ///< lower triangles
    std::vector<char> found;
    double non_finite = 0.0;           ///< the finite check of the data (checkFinite) in the same pass
    bool force_stage = true;
  };
  /// Sorts the model's effects by how they depend on g_S (seen on the probe samples).
  void classifyEffects(const Problem& pb, int stride);
  /// Y4 of sample i into wk.Y4 (wk.c holds the sample with g_S = 0 after it).
  void evaluate(const Problem& pb, int i, Work& wk) const;
  /// After evaluate(): whether the full regressor at g_check_B equals the affine combination.
  bool affine(const Problem& pb, const Vec3& g_check_B, Work& wk) const;
  /// The probe samples: the affine check and the first guess of the entries of Y4 in use.
  bool probeEntries(const Problem& pb, const Vec3& g_check_B, int stride, Work& wk, std::vector<char>* used) const;
  /// B_a's column maps for the entries in use, and the scratch for B_a and the scores.
  void layoutColumns(const std::vector<char>& used, int n);
  LeftOut leftOutEntries(const std::vector<char>& used) const;
  /// Samples [begin, end) of one pass: B_a's rows, their Gram matrices, the entries left out but
  /// non-zero, the finite check (pass 0) and the force stage's data.
  void runRange(const Problem& pb, int pass, int begin, int end, const LeftOut& lo, bool force_stage, Work& wk,
                Part* part);
  /// One pass over every sample (two ranges from internal::kParallelRows on): G_ gets the sum of the
  /// ranges' Gram matrices, the result their found entries, finite check and force stage (no G).
  Part runPass(const Problem& pb, int pass, const LeftOut& lo, bool force_stage, Work& main_work);

  /// v with B_a v = y_a - A_a(g_B) theta.
  Eigen::VectorXd residualMix(int a, const Vec3& g_B, const Eigen::VectorXd& theta) const;

  int p_ = 0;
  bool gram_ = false;
  /// Row-major: a sample's row is written at once (column-major, its c_a entries would sit on c_a
  /// pages, N * 8 bytes apart).
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<RowMatrix> rowsOf(int a) {
    return {data_ + b_offset_[static_cast<std::size_t>(a)], n_, b_cols_[static_cast<std::size_t>(a)]};
  }
  Eigen::Map<const RowMatrix> rowsOf(int a) const {
    return {data_ + b_offset_[static_cast<std::size_t>(a)], n_, b_cols_[static_cast<std::size_t>(a)]};
  }
  double* rowOf(int a, Eigen::Index i) {
    return data_ + b_offset_[static_cast<std::size_t>(a)] + i * b_cols_[static_cast<std::size_t>(a)];
  }
  ThreadScratch scratch_;
  double* data_ = nullptr;                   ///< the scratch: B_a per axis (N x c_a, row-major), scores
  Eigen::Index n_ = 0;                       ///< samples (rows of B_a)
  std::array<Eigen::Index, 6> b_cols_{};     ///< c_a
  std::array<std::size_t, 6> b_offset_{};    ///< first double of B_a in data_
  std::size_t s_offset_ = 0;                 ///< first double of the scores in data_
  std::array<Eigen::MatrixXd, 6> G_;         ///< per axis, B_a^T B_a (lower triangle)
  std::array<Eigen::MatrixXd, 6> R_;         ///< per axis, R_a^T R_a = B_a^T B_a (c_a or min(N, c_a) rows)
  std::array<std::vector<int>, 6> col_;      ///< (k p + j) or 4p (y) -> column of B_a, or -1
  std::array<std::vector<int>, 6> src_;      ///< column of B_a (not y) -> entry 6 (k p + j) + a of Y4
  std::array<Eigen::Index, 6> offset_{};     ///< first stacked row of each axis
  Eigen::Index rows_ = 0;
  std::array<Eigen::MatrixXd, 4> P_;         ///< stacked R columns of A0, E0, E1, E2
  Eigen::VectorXd Py_;                       ///< stacked R column of y
  Eigen::VectorXi axis_of_row_;
  bool force_stage_ = false;                 ///< B_a holds the static force stage's data (initialTilt)
  int c_mass_ = -1;
  int c_f0_[3] = {-1, -1, -1};
  std::vector<const effects::Effect*> fixed_effects_;    ///< evaluated once, at g_S = 0
  std::vector<const effects::Effect*> gravity_effects_;  ///< evaluated at g_S = 0 and the three base axes
  /// Non-zero entries e (of 6 x p, column-major) of sum_j g_S(j) D_j over the constant-slope
  /// effects, with their (D_0, D_1, D_2).
  std::vector<int> slope_entry_;
  std::vector<Vec3> slope_value_;
};

}  // namespace ftid::identify::internal
