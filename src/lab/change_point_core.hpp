#pragma once
// The change-point scan's shared core (change_point_scan.cpp) and its second look, the change that
// ends (change_point_window.cpp): the scan's data, the suffix sums it sweeps, the exact fit with
// steps. Private to ftid_lab (docs/analyze.md "Change points"; the statistics are in
// include/ftid/lab/change_point.hpp).
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ftid/lab/change_point.hpp"
#include "ftid/lab/verdict.hpp"
#include "lab_internal.hpp"

namespace ftid::lab::detail::cpscan {

using Design = Engine::Design;

constexpr int kMaxGrid = 1000;            // splits scanned at most (a coarser grid on long logs)
constexpr int kMinSegment = 20;           // samples on either side of a split, at least
constexpr double kArgmaxVariance = 26.0;  // Var of argmax_s (W(s) - |s|/2) (Bai 1997)
constexpr double kRankTolerance = 1e-9;   // of the step's information matrix (equilibrated)

struct Kind {
  std::string name;    // "payload" or "offsets"
  std::vector<int> u;  // positions in ScanData::cols
};

/// The regressor and residual a scan reads (whitened rows of the fitting samples).
struct ScanData {
  const Engine* eng = nullptr;
  Design X;                 // base design, measurement last
  int p = 0;                // its parameter columns
  int n = 0;                // fitting samples
  Eigen::VectorXd r;        // residual of the base fit per row of the fitting samples
  Eigen::MatrixXd a_inv;    // (X^T X)^+ on the fitting rows
  std::vector<int> cols;    // the step columns of every kind (X columns)
  std::vector<std::string> names, units;
  std::vector<Kind> kinds;
  double sigma2 = 1.0;      // residual variance of the base fit (whitened)
  int dof = 1;              // its residual degrees of freedom
  Design xs;                // the step columns of X, contiguous (rows of the fitting samples)
  std::vector<int> rows;    // rows[6 i + a]: the row of sample i, axis a
  double scale_sd = 0.0;    // colourScaleSd
};

/// The pseudo-inverse of one split's step information Z^T M Z for one kind.
struct SplitForm {
  Eigen::MatrixXd inv;
  int rank = 0;
};

/// One scan against `base` on rc's engine: the best split (and a second one after it, when
/// significant), its exact fit and the scan's p-value.
struct Scan {
  ScanData data;
  Kind kind;
  int k = -1;
  int k2 = -1;           // a second change of the same kind (secondSplit), -1: none
  double p_scan = 1.0;
  std::vector<int> splits() const { return k2 > 0 ? std::vector<int>{k, k2} : std::vector<int>{k}; }
  Linearization lin;
  Solution sol;
};

/// Adds sample i's rows to the sums C = sum x_S x^T (optional) and v = sum x_S r.
inline void addSample(const ScanData& s, int i, Eigen::MatrixXd* c, Eigen::VectorXd& v, const Eigen::VectorXd& r) {
  for (int a = 0; a < 6; ++a) {
    const int row = s.rows[static_cast<std::size_t>(6 * i + a)];
    const auto x = s.xs.row(row);
    v.noalias() += r(row) * x.transpose();
    if (c != nullptr) c->noalias() += x.transpose() * s.X.row(row).head(s.p);
  }
}

/// Calls f(position, C, v) at every split ks[position] (increasing) with the sums over the
/// samples from the split to the end of the fitting log (the step columns' side).
template <class F>
void sweep(const ScanData& s, const std::vector<int>& ks, bool with_c, const Eigen::VectorXd& r, F f) {
  const auto q = static_cast<Eigen::Index>(s.cols.size());
  Eigen::MatrixXd c_total = Eigen::MatrixXd::Zero(with_c ? q : 0, s.p), c = c_total;
  Eigen::VectorXd v_total = Eigen::VectorXd::Zero(q), v = v_total;
  for (int i = ks.empty() ? s.n : ks.front(); i < s.n; ++i) addSample(s, i, with_c ? &c_total : nullptr, v_total, r);
  int i = ks.empty() ? 0 : ks.front();
  for (std::size_t g = 0; g < ks.size(); ++g) {
    while (i < ks[g]) addSample(s, i++, with_c ? &c : nullptr, v, r);
    f(g, c_total - c, v_total - v);
  }
}

/// The scan's data for `base` on rc's engine: its design, residual and the step columns' rows.
ScanData scanData(const RankContext& rc, const Fitted& base);
/// One kind's blocks of a split's suffix sums: cz = Z^T X (q x p) and zz = Z^T Z (q x q).
void kindBlocks(const ScanData& s, const Kind& kind, const Eigen::MatrixXd& c_suffix, Eigen::MatrixXd& cz,
                Eigen::MatrixXd& zz);
/// The pseudo-inverse of the step information Z^T M Z of one kind from its suffix sums.
SplitForm splitForm(const ScanData& s, const Kind& kind, const Eigen::MatrixXd& c_suffix);
/// The kind's entries of v.
Eigen::VectorXd sub(const Eigen::VectorXd& v, const Kind& kind);
/// log of the chi-square survival function, also beyond double's range.
double logSurvival(double chi2, int dof);
/// The splits scanned: at most step_cap, kMinSegment (or n / 50) from either end.
std::vector<int> gridOf(int n, int step_cap);
/// The whitened design of the base model with one set of step columns of `kind` per split in `at`.
Design stepDesign(const ScanData& s, const effects::Model& model, const Linearization& lin, const Kind& kind,
                  const std::vector<int>& at, bool whitened = true);
/// The base model refitted with the steps at `at`, the tilt re-linearised `passes` times.
std::pair<Linearization, Solution> fitWithSteps(const ScanData& s, const Fitted& base, const Kind& kind,
                                                const std::vector<int>& at, int passes);
/// The change point at split k, the m-th step set of `sol`.
ChangePoint describe(const ScanData& s, const Kind& kind, const Solution& sol, int k, int m);
/// The scan's steps fitted exactly with the tilt re-linearised (the fit judged and reported).
Scan relinearised(Scan sc, const Fitted& base);

// ---- change_point_window.cpp: the change that ends

/// A second change after a split: where, its p-value over the splits tried, its degrees of freedom.
struct Second {
  int e = -1;
  double p = 1.0;
  double z = -1e300;
  int rank = 0;
};

/// The second change after sc.k (binary segmentation; its p-value counts every split tried).
Second secondChange(const Scan& sc);
/// The rule's inputs for a change point: one more candidate of the family per look at the log.
RuleInputs changeRule(const RankContext& rc, double p, int added_params, int looks = 1);
/// The scan with a second change after its split when the rule finds that one significant.
Scan withSecond(const RankContext& rc, Scan sc, Second& second);
/// The best window [a, b) of a coarse grid per kind, each as a scan with two splits, in the order
/// of their statistic; each p counts every window and kind tried.
std::vector<Scan> windowScans(const RankContext& rc, const Fitted& base);
/// The rule on the windows in turn (each fitted as two steps, judged on its held-out error against
/// the start); the first recommended, or nothing.
std::vector<ChangePoint> judgeWindow(const RankContext& rc, const Fitted& base, const std::vector<Scan>& wins,
                                     double best_smooth_reduction);

}  // namespace ftid::lab::detail::cpscan
