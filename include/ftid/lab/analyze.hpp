#pragma once
// The model laboratory behind `ftid analyze` (docs/analyze.md): fit a composed model with held-out
// validation, show per axis how far the held-out residual is above the sensor noise floor, where
// (in time) and with what (measured signals) the residual goes, rank the effects the model lacks by
// how much each reduces the held-out residual, judge each by one decision rule (ftid/lab/verdict.hpp:
// family-wise significance decides; identifiability and physics refuse with a reason), and walk to
// the model the rule supports (forward with look-ahead, backward elimination; any start, same end).
//
// Everything here is offline (not real-time). Frames and units: docs/conventions.md.
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ftid/samples/context.hpp"
#include "ftid/common/types.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/saturation.hpp"
#include "ftid/lab/change_point.hpp"
#include "ftid/lab/dynamics.hpp"
#include "ftid/lab/spectrum.hpp"
#include "ftid/lab/verdict.hpp"

namespace ftid::lab {

using effects::SampleContext;

struct AnalyzeOptions {
  std::string model = "paper";      ///< starting model, e.g. "paper" or "paper+rigid_body"
  int folds = 5;                    ///< contiguous time blocks for k-fold validation (>= 2)
  bool explain = false;             ///< walk to the model the rule supports (docs/analyze.md "Explain")
  int max_explain_steps = 10;       ///< steps of the path (additions and removals)
  /// Candidate effects to try; empty = every registered named effect not in the model plus the
  /// default generic menu (defaultGenericMenu()).
  std::vector<std::string> candidates;
  double family_alpha = 1e-3;       ///< family-wise significance level of a ranking (lab/verdict.hpp)
  double min_relative_reduction = 0.0;  ///< a recommended effect must cut the held-out residual (sum of
                                         ///< squares) by more than this fraction; 0: it must fall (implied by
                                         ///< the held-out test; docs/analyze.md, "The verdict"). Tests only.
  /// The held-out margin of the two searches whose significance is still an in-sample test (a
  /// change point, the reading's dynamics; docs/analyze.md): their model must cut the held-out sum
  /// of squares by more than this fraction. The ranking's candidates need none (the held-out test).
  double search_heldout_margin = 0.01;
  int top_windows = 3;              ///< failing time windows reported
  int window_count = 20;            ///< the log is cut into this many windows
  int top_correlations = 8;
  double max_delay_s = 1.0;         ///< delay search range of `sensor_delay` [s]
  /// The sensor's noise std per axis from its data sheet (`--noise`); unset: estimated from the
  /// data (identify::estimateNoiseFloor, docs/analyze.md "The noise floor").
  std::optional<Vec6> noise_std;
  /// Glitches: samples whose residual (minus its running median over 7 samples) exceeds this
  /// many robust standard deviations on any axis are left out of every fit (0 = off).
  double glitch_threshold = 6.0;
  /// Saturation (issue 22, docs/analyze.md "Saturation"): samples at a range limit (flat tops, or
  /// the rated range `--rated-range`) are left out of every fit and sum, as glitches are.
  identify::SaturationOptions saturation;
  /// Sensor and mount dynamics (issue 22, ftid/lab/dynamics.hpp): search a filter of the reading
  /// even when the last model's held-out residual is within 1.2x the noise floor on every axis
  /// with no spectral peak (by default it is searched only when something is left; tests of its
  /// false-alarm rate set this).
  bool always_search_dynamics = false;
  /// Progress lines (stderr in the CLI); may be empty.
  std::function<void(const std::string&)> progress;
};

/// Generic effects tried by default besides the named ones.
std::vector<std::string> defaultGenericMenu();

/// Dense white noise (today's estimator, identify::differenceNoiseStd at stride 1):
/// sensor noise floor of one channel from its high-frequency content: the robust (MAD) standard
/// deviation of the 4th-order differences divided by sqrt(70) (the sum of the squared binomial
/// coefficients 1 4 6 4 1), which equals the white-noise std while any smooth signal (motion at a
/// few Hz sampled at >= 100 Hz) is suppressed by (2 pi f dt)^4. Needs >= 8 samples.
double estimateNoiseStd(const std::vector<double>& x);

/// p-value of a chi-square statistic with `dof` degrees of freedom (upper tail).
double chiSquareSurvival(double statistic, double dof);

/// The same when the statistic's scale is itself uncertain: statistic = r x chi2(dof) with
/// ln r normal (0, log_scale_sd^2), i.e. E[chiSquareSurvival(statistic / r, dof)]. The noise's
/// estimated colour makes the scale of a slow candidate's F statistic uncertain (docs/analyze.md,
/// "Significance without false alarms"). log_scale_sd = 0: chiSquareSurvival.
double chiSquareSurvivalUncertainScale(double statistic, double dof, double log_scale_sd);

/// Upper tail P(Q >= x) of Q = sum_k lambda_k chi2_1 (independent; weights of either sign), the
/// law of a held-out gain under "the effect is not there" (docs/analyze.md, "The verdict: one
/// rule"). The saddlepoint approximation of Lugannani and Rice above mean + sd/2 (relative error a
/// few per cent with several weights, up to 15 % with one, down to the smallest doubles), the
/// normal approximation below. No positive
/// weight: 1.
double weightedChiSquareSurvival(const std::vector<double>& lambda, double x);
/// The same with an uncertain scale (as chiSquareSurvivalUncertainScale).
double weightedChiSquareSurvivalUncertainScale(const std::vector<double>& lambda, double x, double log_scale_sd);

struct ParamEstimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std = 0.0;
};

struct FailWindow {
  double t_start = 0.0;   ///< [s] since the first sample (of the evaluated log)
  double t_end = 0.0;
  double ratio = 0.0;     ///< RMS of the noise-normalised residual over the axes (1 = noise floor)
  int worst_axis = 0;     ///< 0..5 = fx..tz
};

struct SignalCorrelation {
  std::string signal;     ///< e.g. "alz", "q6", "temp", "dfx/dt"
  int axis = 0;           ///< residual axis 0..5
  double r = 0.0;         ///< Pearson correlation of the held-out residual with the signal
  bool significant = false;  ///< |r| above 5 / sqrt(N)
};

struct CandidateResult {
  std::string effect;               ///< as typed on the command line, e.g. "rigid_body"
  std::string description;          ///< physical meaning in words
  int added_params = 0;             ///< rank gained
  double relative_reduction = 0.0;  ///< of the held-out (noise-weighted) sum of squares, clamped to 0..1
  /// Same on the fitting data (in-sample), clamped to 0..1: never used for ranking or significance
  /// (a flexible candidate always gains in-sample); reported for comparison.
  double fit_relative_reduction = 0.0;
  Vec6 residual_rms = Vec6::Zero(); ///< held-out, per axis, with the effect added
  double f_statistic = 0.0;         ///< nested-model F on the fitting data (in-sample; shown, does not decide)
  double p_value = 1.0;             ///< the candidate's own p-value: of its held-out gain (the held-out test)
  /// The rule's verdict (lab/verdict.hpp): family_p = min(1, m p) is the one number that decides
  /// significance; `reason` says in words why a candidate was not taken ("" when recommended).
  Verdict verdict = Verdict::kNotSignificant;
  double family_p = 1.0;
  std::string reason;
  bool significant = false;         ///< verdict == recommended
  double delta_bic = 0.0;           ///< held-out BIC change (negative = better); ranking key
  std::string next_command;
  std::string note;                 ///< why it was skipped, if it was
  bool skipped = false;
  /// Refused by the rule (not identifiable or not physical; never taken by --explain):
  bool confounded = false;
  std::string confound;             ///< which parameters and why, in words (the refusal's reason)
  std::string separating_motion;    ///< what motion would tell them apart
};

/// Glitches found and left out (times since the first sample of their log).
struct OutlierReport {
  int count = 0;
  std::vector<double> times;        ///< [s]
  std::vector<int> axes;            ///< worst axis of each
};

struct ExplainStep {
  std::string model;
  std::string added;                ///< effect added at this step ("" for the start or a removal)
  std::string removed;              ///< effect removed at this step (backward elimination), else ""
  Vec6 residual_rms = Vec6::Zero(); ///< held-out per axis
  double total_ratio = 0.0;         ///< RMS over axes of residual / noise floor
  double p_value = 1.0;             ///< of the added (or removed) effect
  double family_p = 1.0;            ///< its family-wise p-value (the rule's number)
  double heldout_sse = 0.0;         ///< weighted held-out sum of squares of the step's model
};

/// One fitted model with held-out residuals (the core of every step).
struct ModelReport {
  std::string model;
  std::vector<ParamEstimate> params;          ///< linear parameters + tilt_u, tilt_v + derived
  double tilt_u_rad = 0.0, tilt_v_rad = 0.0;
  bool tilt_estimated = false;
  Vec6 raw_rms = Vec6::Zero();                ///< of the evaluated reading
  Vec6 residual_rms = Vec6::Zero();           ///< held-out
  Vec6 fit_residual_rms = Vec6::Zero();       ///< in-sample (all fitting data)
  double condition_number = 0.0;
  std::optional<effects::InertiaAboutCom> inertia;  ///< when the model has rigid_body
};

struct AnalysisResult {
  std::string log;                       ///< the analysed log (for commands)
  std::string validate_log;              ///< "" for k-fold
  int n_samples = 0;                     ///< fitting samples
  int n_eval = 0;                        ///< held-out samples evaluated
  int folds = 0;
  /// k-fold: the time [s] at which each held-out block after the first begins (folds - 1 values;
  /// identify::foldBoundaries: equal shares of the moving samples); empty with a validation log.
  std::vector<double> fold_start_t;
  Vec6 noise_floor = Vec6::Zero();
  std::string noise_method;              ///< white, coloured, static_poses, not_observable, data_sheet
  std::string noise_detail;              ///< how, in words
  Vec6 noise_ar1 = Vec6::Zero();         ///< lag-1 noise correlation per axis (prewhitening)
  Vec6 noise_ar1_std = Vec6::Zero();     ///< its standard error (0: not fitted to a spectrum)
  OutlierReport outliers;
  /// Saturation (issue 22): axes at a range limit (identify::findSaturation on the fitting log's
  /// readings, then the validation log's; fraction: of that log); their samples are left out of
  /// every fit and held-out sum.
  std::vector<identify::SaturatedAxis> saturation;
  int saturated_samples = 0;             ///< samples left out as saturated (all axes)
  std::vector<std::string> warnings;     ///< one line each
  ModelReport report;                    ///< the starting model
  std::vector<FailWindow> windows;       ///< largest held-out residual first
  std::vector<double> window_ratio;      ///< every window's ratio, in time order
  double window_length_s = 0.0;
  std::vector<SignalCorrelation> correlations;  ///< strongest first
  std::vector<CandidateResult> candidates;      ///< best first (recommended ones first)
  double family_alpha = 0.0;                    ///< the rule's family-wise significance level
  /// m of min(1, m p): the menu's effects that can be tried on this data, one number for every
  /// ranking and step of the path (independent of the starting model).
  int family_size = 0;
  /// AnalyzeOptions::min_relative_reduction (0: a recommended effect lowers the held-out sum of
  /// squares, as its significant held-out gain implies).
  double heldout_margin = 0.0;
  std::vector<ExplainStep> steps;               ///< with explain: the path, first = start
  std::optional<ModelReport> final_report;      ///< with explain: the last model of the path
  /// Why the last model (final, else the starting one) is not physically possible, one line each;
  /// empty when it is. The lab then gives no advice to write or export its parameters.
  std::vector<std::string> unphysical;
  /// When the last model is possible but `ftid identify --out` would refuse to write it (the data
  /// do not determine its inertia; writeRefusal): identify's reason, else "". The lab then gives
  /// no advice to write it, and says what would.
  std::string unwritable;
  /// With unwritable: the last model without rigid_body, which identify can write ("" if none).
  std::string writable_alternative;
  /// With explain: the ranking against the last model of the path (why each was not taken).
  std::vector<CandidateResult> final_candidates;
  /// With explain: effects of the last model the rule does not support (judged against the model
  /// without them) that the path keeps because removing them would raise the held-out error (a
  /// step never does); empty when the rule supports each.
  std::vector<CandidateResult> kept_unsupported;
  // Time series of the evaluated data for the report (starting model).
  std::vector<double> t;
  Eigen::Matrix<double, 6, Eigen::Dynamic> measured;
  Eigen::Matrix<double, 6, Eigen::Dynamic> predicted;   ///< held-out prediction
  /// With explain: the final model's held-out residual on the same samples (columns of t);
  /// empty otherwise. The report overlays it on the starting model's (before / after).
  Eigen::Matrix<double, 6, Eigen::Dynamic> final_residual;
  std::vector<double> top_signal;                       ///< values of correlations[0].signal
  // Extra log columns as candidate signals (docs/analyze.md): the columns taken as signals of the
  // correlations and (unless --candidates) of payload(<column>) and poly(<column>,1), in log order.
  std::vector<std::string> extra_signals;
  double seconds = 0.0;                                 ///< wall time of the analysis
  std::string robot_urdf;  ///< robot description used (analyzeLogFiles; "" otherwise), for provenance
  // Change in time (issue 22, lab/change_point.hpp): a payload or offsets step found in the fitting
  // log against the starting model; when there is one, --explain does not walk (smooth effects
  // would imitate the step) and no parameters are advised to be written.
  std::vector<ChangePoint> change_points;
  double change_point_scan_p = 1.0;  ///< the scan's p-value, splits accounted for (1: not scanned)
  // Sensor and mount dynamics (issue 22): the spectrum and autocorrelation of the last model's
  // held-out residual against the noise model, with the motion band (ftid/lab/spectrum.hpp).
  ResidualSpectrum spectrum;
  DynamicsCheck dynamics;  ///< a filter of the reading on the last model (ftid/lab/dynamics.hpp)
  /// The sensor's IMU (issue 23, docs/analyze.md "The IMU"): its frame, bias and delay from the gyro,
  /// its tilt and bias from the accelerometer (IMU against kinematics, residual RMS as `sigma`), and
  /// the comparisons with the last model's mounting, sensor_delay and tilt (or the configuration).
  identify::ImuReport imu;
};

/// Runs the analysis on contexts built from the log (samples::buildContexts). `validate`, if
/// given, is evaluated with the model fitted on all of `fit` (instead of k-fold). `log_name` and
/// `validate_name` are used in messages and next commands. Contexts need not have g_S set (the
/// tilt is estimated when the model has `tilt`, else g_S is computed for zero tilt).
/// Throws ConfigError for an unknown model/effect, IdentificationError if the data cannot
/// determine the starting model, DataError for too little data.
AnalysisResult analyze(const std::vector<SampleContext>& fit, const std::vector<SampleContext>* validate,
                       const AnalyzeOptions& options, const std::string& log_name = "LOG",
                       const std::string& validate_name = "");

/// Human-readable report (the table, the failing windows and signals, the ranking, the path).
std::string formatText(const AnalysisResult& result);
/// One JSON object: model, residual_rms, noise_floor, raw_rms, candidates, steps, parameters, ...
std::string formatJson(const AnalysisResult& result);
/// One self-contained HTML file with inline SVG plots (no scripts, no network references).
std::string renderHtml(const AnalysisResult& result);

}  // namespace ftid::lab

namespace ftid::lab {

/// `ftid analyze --max-rows` default: an ftid log's rows held (analyze keeps several fits and
/// their residuals per row; docs/log-format.md "Limits").
inline constexpr std::size_t kDefaultAnalyzeMaxRows = 150000;

/// `ftid analyze` on files: reads the log(s) (docs/log-format.md), builds the contexts with the
/// robot kinematics (default robot: defaultRobotUrdf()), and runs analyze().
struct AnalyzeFilesRequest {
  std::string log_path;
  std::string validate_path;   ///< "" = k-fold
  std::string robot_urdf;      ///< "" = default
  AnalyzeOptions options;
  samples::ContextOptions context;  ///< e.g. wrench_in_base for `--wrench-frame base`
  // Time window (issue 22, change points; `--t-from`, `--t-to`): only samples of the fitting log with
  // t_from <= t < t_to (its time column, s) are analysed.
  double t_from = -std::numeric_limits<double>::infinity();
  double t_to = std::numeric_limits<double>::infinity();
};
AnalysisResult analyzeLogFiles(const AnalyzeFilesRequest& request);

/// `ftid analyze`'s reading of its logs: as analyzeLogFiles, but each log is read through
/// samples::loadLogContexts (an ftid log or a UR recording, with request.context.input's
/// `--wrench-log`; docs/log-format.md). A log too short is refused first (checkEnoughSamples);
/// then identify's set-up diagnosis (wrench frame, mount, angle units; setup_check.hpp) sends its
/// findings to options.progress. The validation log is read without the wrench log, its model
/// time counting from the fitted log's origin. result.robot_urdf names the robot used.
AnalysisResult analyzeRecordings(const AnalyzeFilesRequest& request);

/// Throws DataError naming request.log_path when `fit` has fewer samples than the analysis
/// needs (20 with a validation log, else 20 per held-out block), saying what would do: repeated
/// readings at each pose for a static set (all |w_S| < 1e-3 rad/s; poses counted by the 'pose'
/// column's changes), else a longer recording; fewer blocks, a validation log, or the
/// identification alone. (lab::analyze's own check says only how many it needs.)
void checkEnoughSamples(const samples::ContextSet& fit, const AnalyzeFilesRequest& request);

/// Writes text atomically (temporary file + rename); throws Error naming the file on failure.
void writeTextFileAtomically(const std::string& path, const std::string& text);

}  // namespace ftid::lab
