#pragma once
// The fitting core's nonlinear step on stacked, treated data (src/identify/nonlinear_fit.cpp;
// docs/identification.md "The nonlinear step on treated data"). Used by the model laboratory
// (`ftid analyze`, src/lab/engine.cpp) for every fit and candidate screen.
//
// The data: sample contexts (several logs one after the other) and their treatment
// (DataTreatment): per-axis weights, an optional per-axis AR(1) prewhitening filter that restarts
// at given samples, per-(axis, sample) row weights applied to the filtered rows (0: the row is out,
// e.g. a glitch), the log boundaries (time derivatives and the delay shift stay inside a log), the
// fitting samples (a prefix; the rest are held out: they get predictions and Jacobian columns, but
// no say in the fit) and the delay search range.
//
// The stacked regressor (Design): one row per (sample, axis), ordered filter run by filter run and
// inside a run axis by axis (rowOf), so every (run, axis) is a contiguous time series; the
// measurement is the last column. Rows are weighted, then filtered, then row-weighted.
//
// The nonlinear parameters (tilt U, V; mounting roll, pitch, yaw; delay) and the signals derived
// from the modelled wrench (the wrench itself for crosstalk, its time derivative) are found by
// Gauss-Newton on the joint problem [Y(phi) | J_phi] [theta; d phi] = w (NonlinearFit::fit):
//   tilt      analytic columns: the regressor is affine in g_S (only gravity reads it), so
//             d(Y theta)/dU = (Y(g_S = R_BS^T dg_B/dU) - Y(g_S = 0)) theta, likewise V;
//   mounting  central differences of the prediction in roll, pitch, yaw (h = 1e-5 rad);
//   delay     -d/dt of the prediction (the exact shift's first-order change), started from a scan
//             of the shifted prediction (initialDelayEstimate) on the first log of the fitting data;
//   derived   wrench_model_S = the prediction of the effects that do not read it, iterated to a
//             fixed point together with the steps.
// Each solve is a Gram (normal-matrix) solve on the fitting runs (solveGram), the screening
// solver; convergence: a step below 1e-9 (rad, s) and a derived-signal change below 1e-6 of its
// largest value, at most 30 passes.
#include <array>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "ftid/effects/model.hpp"

namespace ftid::identify {

using effects::SampleContext;
using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// How the samples enter the fit (see the file comment).
struct DataTreatment {
  Vec6 axis_weights = Vec6::Ones();  ///< rows of axis a scaled by this (1 / innovation std)
  /// Lag-1 prewhitening per axis: row_i - phi row_{i-1} inside each filter run, the first row of a
  /// run scaled by sqrt(1 - phi^2) (Prais-Winsten). Zero: no filter on that axis.
  Vec6 ar1 = Vec6::Zero();
  /// First sample of each filter run, increasing, starting with 0 (empty: one run). The fitting
  /// prefix must end at a run boundary.
  std::vector<int> filter_start;
  /// Weights of the filtered rows (6 x N; empty: all 1). exclusionWeights() builds the 0/1 weights
  /// that leave samples out of a filtered fit.
  Mat6X row_weights;
  /// First sample of each log (empty: one log): time derivatives and delay shifts stay inside.
  std::vector<int> segment_start;
  int n_fit = -1;            ///< samples [0, n_fit) are the fitting data (-1: all)
  double max_delay_s = 1.0;  ///< delay search range [-max, max] [s]
};

/// Row weights that leave the `excluded` samples (per sample, nonzero: out) out of a fit on
/// prewhitened rows: the sample's own row and, on a filtered axis, the next row of its run (which
/// the filter makes depend on it) get weight 0; all others 1.
Mat6X exclusionWeights(const std::vector<char>& excluded, const Vec6& ar1, const std::vector<int>& filter_start,
                       int n);

/// A linearisation point: the nonlinear parameters (effects/nonlinear.hpp), their Jacobian columns
/// when appended to the regressor, and the model-derived signals.
struct Linearization {
  double u = 0.0, v = 0.0;      ///< tilt [rad]
  bool tilt_columns = false;    ///< append dY/dU theta, dY/dV theta
  Mat6X j_u, j_v;               ///< per sample (6 x N), when tilt_columns
  Vec3 mount = Vec3::Zero();    ///< mounting roll, pitch, yaw [rad]
  bool mount_columns = false;   ///< append d(Y theta)/d mount (3 columns)
  std::array<Mat6X, 3> j_m;
  double delay = 0.0;           ///< [s] the reading lags the kinematics
  bool delay_column = false;    ///< append d(Y theta)/d delay = -d/dt of the prediction
  Mat6X j_d;
  /// Samples whose delayed kinematics lie inside their log (empty: all); the others get zero rows.
  std::vector<char> active;
  Mat6X w_model;                ///< modelled wrench without the effects that read it (6 x N)
  Mat6X dw_dt;                  ///< its time derivative (6 x N)

  /// Columns appended after the model's parameters: tilt (2), mounting (3), delay (1).
  int extraColumns() const {
    return (tilt_columns ? 2 : 0) + (mount_columns ? 3 : 0) + (delay_column ? 1 : 0);
  }
  int mountColumn(int p) const { return p + (tilt_columns ? 2 : 0); }
  int delayColumn(int p) const { return mountColumn(p) + (mount_columns ? 3 : 0); }
};

/// The stacked, treated data and the nonlinear step on them. Set-up / offline code.
class NonlinearFit {
 public:
  using Design = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// Throws std::invalid_argument if the treatment does not fit the contexts (sizes, run starts,
  /// a fitting prefix that does not end at a run boundary).
  NonlinearFit(std::vector<SampleContext> contexts, DataTreatment treatment);

  const std::vector<SampleContext>& contexts() const { return ctx_; }
  const DataTreatment& treatment() const { return tr_; }
  int size() const { return static_cast<int>(ctx_.size()); }
  int fitSamples() const { return n_fit_; }
  /// Filter runs [begin, end) in order (the row layout).
  const std::vector<std::pair<int, int>>& runs() const { return runs_; }
  /// Row of (sample i, axis a) in a design.
  int rowOf(int i, int a) const;

  /// Weighted, filtered and row-weighted regressor of the model at lin (plus the Jacobian columns
  /// lin asks for) with the measurement as its last column.
  Design design(const effects::Model& model, const Linearization& lin) const;
  /// Same, weighted only (no filter, no row weights): for residual series in N / Nm.
  Design rawDesign(const effects::Model& model, const Linearization& lin) const;
  /// Filters columns [c0, c1) of a raw design in place and applies the row weights
  /// (design() = whiten(rawDesign(), 0, cols)).
  void whiten(Design& X, int c0, int c1) const;
  /// Design of `cand` = `base` + more effects from the base design (same linearisation and
  /// Jacobian columns): copies the base columns and adds the new effects' contributions
  /// (regressors are additive). Falls back to design() if base's columns are not a prefix of cand's.
  /// prepared_ctx: prepared(lin).
  Design designExtended(const effects::Model& base, const Design& base_design, const effects::Model& cand,
                        const Linearization& lin, const std::vector<SampleContext>& prepared_ctx) const;
  /// Augmented Gram [X y]^T [X y] of every (filter run, axis) of a design.
  std::vector<std::array<Eigen::MatrixXd, 6>> runGrams(const Design& X) const;

  /// Contexts with g_S, mounting, delay and the derived signals of lin filled in.
  std::vector<SampleContext> prepared(const Linearization& lin) const;
  /// Modelled wrench (unweighted, 6 x N) of theta (first P entries) at lin.
  Mat6X predict(const effects::Model& model, const Linearization& lin, const Eigen::VectorXd& theta,
                bool exclude_derived) const;
  /// Central differences along time within each log (identify::timeDerivative).
  Mat6X timeDerivative(const Mat6X& w) const;

  /// Jacobian columns of the prediction Y theta at lin (6 x N each); they do not set the flags.
  void tiltColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  void mountColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  void delayColumn(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  /// Marks the samples whose kinematics at t - lin.delay lie inside their own log.
  void updateActive(Linearization& lin) const;

  /// Start: the initial tilt (identify::initialTilt on the fitting samples; level if it fails or
  /// exceeds 0.5 rad) when the model estimates tilt; everything else zero.
  Linearization initial(const effects::Model& model) const;
  /// Least-squares solution (minimum norm) of a design on the fitting runs (Gram solve).
  Eigen::VectorXd solveFit(const Design& X) const;
  /// The nonlinear fit from `start` (see the file comment). Returns the converged linearisation
  /// with the Jacobian columns of the model's nonlinear parameters at the last theta (flags set);
  /// its final linear solve is the caller's (design(model, lin)), followed by completeDerived().
  Linearization fit(const effects::Model& model, const Linearization& start) const;
  /// For a model that does not read the derived signals: fills lin.w_model and lin.dw_dt from its
  /// final theta (what a candidate that reads them starts from). No-op for one that does.
  void completeDerived(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;

 private:
  SampleContext contextAt(int i, const Linearization& lin) const;
  /// Sample i prepared for lin (delay shift within its log, mounting, gravity g_B).
  SampleContext prepare(int i, const Linearization& lin, const Vec3& g_B, const Mat3& R_SM) const;
  int segmentOf(int i) const;

  std::vector<SampleContext> ctx_;
  DataTreatment tr_;
  int n_fit_ = 0;
  std::vector<std::pair<int, int>> runs_;
  std::vector<int> run_of_;    ///< filter run of every sample
  std::vector<double> times_;  ///< t of every sample
};

}  // namespace ftid::identify
