#pragma once
// The fitting engine of the model laboratory (private to ftid_lab).
//
// All fits are weighted linear least squares on the stacked regressor, rows scaled by the axis
// weights 1 / noise floor. The data are cut into blocks; the normal matrices of the blocks are
// formed once per design, so the fit of every fold is a sum of block matrices and costs P^3, not
// N P^2 (10 s at 1 kHz: 60,000 rows). Solves are identify::solveGram (ftid/identify/normal_equations.hpp):
// the column-equilibrated normal matrix with an eigen-decomposition (pseudo-inverse: directions
// below 1e-12 of the largest eigenvalue, i.e. a condition number of 1e6 of the scaled regressor,
// count as not determined). Time derivatives and the initial tilt are identify's as well
// (identify::timeDerivative, identify::initialTilt).
//
// Two quantities are not linear: the base tilt (U, V) and the signals derived from the modelled
// wrench (its time derivative for sensor_delay, the wrench itself for crosstalk). fitFully() finds
// them by Gauss-Newton (tilt columns dY/dU theta, dY/dV theta appended to the regressor) and by
// re-computing the derived signals from the prediction. Folds then re-fit every linear parameter
// plus a first-order tilt correction, holding the linearisation point of the full fit.
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/effects/model.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab::detail {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

struct Block {
  int begin = 0;   ///< first sample
  int end = 0;     ///< one past the last
  bool fit = true; ///< part of the fitting data (false: external validation log)
};

struct Dataset {
  std::vector<SampleContext> ctx;  ///< fitting samples, then validation samples
  int n_fit = 0;
  std::vector<Block> blocks;       ///< k-fold: the folds; external: [fit, validate]
  bool external = false;
  Vec6 weights = Vec6::Ones();     ///< 1 / innovation std of the noise (= 1 / noise floor if white)
  Vec6 ar1 = Vec6::Zero();         ///< lag-1 noise correlation per axis: rows are prewhitened
                                   ///< x_i - phi x_{i-1} along time inside each block (first row
                                   ///< of a block scaled by sqrt(1 - phi^2), Prais-Winsten)
  std::vector<char> excluded;      ///< per sample: a glitch, left out of every fit and sum
  bool static_data = false;        ///< a static pose set (the robot at rest in every sample)
  std::vector<int> segment_start;  ///< sample index where a log starts (for time derivatives)
  double max_delay_s = 1.0;        ///< delay search range of `sensor_delay` [s]

  int size() const { return static_cast<int>(ctx.size()); }
  /// Test block of fold f, and whether block b is in the training set of fold f.
  int foldCount() const { return external ? 1 : static_cast<int>(blocks.size()); }
  int testBlock(int f) const { return external ? 1 : f; }
  bool trains(int f, int b) const {
    return blocks[static_cast<std::size_t>(b)].fit && (external || b != f);
  }
};

/// The linearisation point: the nonlinear parameters (effects/nonlinear.hpp) and the
/// model-derived signals.
struct Linearization {
  double u = 0.0, v = 0.0;
  bool tilt_columns = false;    ///< append dY/dU theta, dY/dV theta
  Mat6X j_u, j_v;               ///< per sample (6 x N), when tilt_columns
  Vec3 mount = Vec3::Zero();    ///< mounting roll, pitch, yaw [rad]
  bool mount_columns = false;   ///< append d(Y theta)/d mount (3 columns)
  Mat6X j_m[3];
  double delay = 0.0;           ///< [s] the reading lags the kinematics
  bool delay_column = false;    ///< append d(Y theta)/d delay = -d/dt of the prediction
  Mat6X j_d;
  /// Samples whose delayed kinematics lie inside their log (empty: all); the others get zero rows.
  std::vector<char> active;
  /// Columns appended after the model's parameters: tilt (2), mounting (3), delay (1).
  int extraColumns() const { return (tilt_columns ? 2 : 0) + (mount_columns ? 3 : 0) + (delay_column ? 1 : 0); }
  int mountColumn(int p) const { return p + (tilt_columns ? 2 : 0); }
  int delayColumn(int p) const { return mountColumn(p) + (mount_columns ? 3 : 0); }
  Mat6X w_model;                ///< modelled wrench without derivative-reading effects (6 x N)
  Mat6X dw_dt;                  ///< its time derivative (6 x N)
};

/// Result of solving one design on the blocks.
struct Solution {
  int p = 0;                    ///< columns (parameters + tilt columns)
  int rank = 0;
  Eigen::VectorXd theta;        ///< full-data (all fit blocks) solution
  Eigen::MatrixXd covariance;   ///< sigma^2 (X^T W X)^+ of the full-data solution (weighted)
  /// Directions the data do not determine (rank < p): unit columns over the parameters in
  /// column-scaled coordinates (entries show which parameters enter only in that combination).
  Eigen::MatrixXd null_space;
  double sse_fit = 0.0;         ///< weighted in-sample SSE of the full-data fit
  double sigma2 = 0.0;
  int rows_fit = 0;
  double condition_number = 0.0;
  Vec6 sse_fit_axis = Vec6::Zero();  ///< unweighted, per axis
  Mat6X heldout_residual;       ///< N / Nm, test samples in order of the test blocks (with raw)
  double sse_heldout = 0.0;     ///< weighted
  Vec6 sse_heldout_axis = Vec6::Zero();  ///< unweighted
  int n_heldout = 0;            ///< test samples not excluded
};

class Engine {
 public:
  explicit Engine(Dataset data);
  const Dataset& data() const { return data_; }

  /// Weighted regressor of the model at the linearisation (plus tilt columns if lin says so) with
  /// the weighted measurement as its last column. Row-major; rows ordered block by block, inside a
  /// block axis by axis (rowOf()), so every (block, axis) is a contiguous row range.
  using Design = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Design design(const effects::Model& model, const Linearization& lin) const;
  /// Same without prewhitening and exclusions (for the reported residual series).
  Design rawDesign(const effects::Model& model, const Linearization& lin) const;
  /// with_folds = false skips the held-out part (inner iterations); with `raw` (rawDesign of the
  /// same model) fills Solution::heldout_residual in N / Nm and takes the per-axis held-out sums
  /// from it (needed only for the reported model). Without it the per-axis sums are the whitened
  /// ones scaled by 1 / (1 - phi^2) (the marginal scale of AR(1) noise).
  Solution solve(const Design& X, bool with_folds = true, const Design* raw = nullptr) const;
  /// Contexts with g_S and the derived signals of the linearisation filled in.
  std::vector<SampleContext> prepared(const Linearization& lin) const;
  /// Design of `cand` = `base` + more effects, from the base design (same linearisation, same tilt
  /// columns): copies the base columns and adds only the new effects' contributions (regressors
  /// are additive). Falls back to design() if the base columns are not a prefix of cand's.
  Design designExtended(const effects::Model& base, const Design& base_design, const effects::Model& cand,
                        const Linearization& lin, const std::vector<SampleContext>& prepared_ctx) const;
  /// Row of (sample i, axis a) in a design.
  int rowOf(int i, int a) const;

  /// Full nonlinear fit (tilt, derived signals); start from `start` (tilt, reference prediction).
  /// Returns the converged linearisation (tilt columns for the fitted theta) and its solution.
  std::pair<Linearization, Solution> fitFully(const effects::Model& model, const Linearization& start) const;

  /// Initial linearisation: the fit's initial tilt (identify::initialTilt, if the model estimates
  /// tilt), derived signals zero.
  Linearization initial(const effects::Model& model) const;

  /// Modelled wrench (unweighted, 6 x N) of theta (first P entries) at the linearisation.
  Mat6X predict(const effects::Model& model, const Linearization& lin, const Eigen::VectorXd& theta,
                bool exclude_derived) const;
  /// Central differences along time, within each log segment (identify::timeDerivative).
  Mat6X timeDerivative(const Mat6X& w) const;
  /// Tilt Jacobian columns J_U, J_V (6 x N) of the model with theta.
  void tiltColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  /// Mounting Jacobian columns (central differences of the prediction in roll, pitch, yaw).
  void mountColumns(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  /// Delay Jacobian column: -d/dt of the prediction (the exact shift's first-order change).
  void delayColumn(const effects::Model& model, Linearization& lin, const Eigen::VectorXd& theta) const;
  /// Marks the samples whose kinematics at t - lin.delay lie inside their own log.
  void updateActive(Linearization& lin) const;

  /// Indices of the evaluated (test) samples in order.
  const std::vector<int>& testSamples() const { return test_samples_; }
  bool excluded(int i) const {
    return !data_.excluded.empty() && data_.excluded[static_cast<std::size_t>(i)] != 0;
  }

 private:
  /// Prewhitens columns [c0, c1) of X in place and zeroes the rows an excluded sample touches.
  void whiten(Design& X, int c0, int c1) const;
  SampleContext contextAt(int i, const Linearization& lin) const;
  /// Sample i prepared for lin (delay shift within its log, mounting, gravity g_B).
  SampleContext prepare(int i, const Linearization& lin, const Vec3& g_B, const Mat3& R_SM) const;
  int segmentOf(int i) const;
  Dataset data_;
  std::vector<int> test_samples_;
  std::vector<int> block_of_;  ///< block index of every sample
  std::vector<double> times_;  ///< t of every sample
};

}  // namespace ftid::lab::detail
