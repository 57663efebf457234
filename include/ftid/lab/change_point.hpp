#pragma once
// Change points in time (docs/analyze.md, "Change points"): where the residual's behaviour changes
// in a log (a payload grasped or released, a tool change, a sensor re-bias), what changed (a step in
// the payload's parameters or in the offsets only) and when, with their uncertainties.
//
// The scan: for the fitted model's linearised, prewhitened regressor X (shared offsets and tilt),
// every candidate split sample k adds the step columns D_k X_S (D_k: 1 from sample k on) of one
// kind: "payload" (S = mass, mass_com_x/y/z and, with rigid_body, the inertia i_s_*) or "offsets"
// (S = the six offsets). The gain of a split, r^T Z (Z^T M Z)^+ Z^T r with M = I - X (X^T X)^+ X^T,
// is chi-square with |S| degrees of freedom under no change; the scan's own multiple comparison
// (many splits, two kinds) is calibrated by simulating its null (min p-value over the scan) on the
// same regressor. The best split is then judged by the laboratory's one rule (lab/verdict.hpp).
#include <string>
#include <vector>

#include "ftid/samples/context.hpp"

namespace ftid::lab {

/// One parameter step of a change point (after minus before).
struct ChangeDelta {
  std::string name;   ///< a linear parameter of the model: mass, mass_com_x, f0_z, i_s_xx, ...
  std::string unit;
  double value = 0.0;
  double std = 0.0;
};

struct ChangePoint {
  double t = 0.0;        ///< [s] in the log's time column: midway between the last sample before
                         ///< and the first sample after the change
  double t_std = 0.0;    ///< [s] half-width of the 1-sigma profile-likelihood interval of t
  std::string kind;      ///< "payload" or "offsets"
  std::vector<ChangeDelta> delta;
  int sample = 0;        ///< first fitting sample after the change
  double p_value = 1.0;  ///< the scan's p-value (the multiple comparison over splits included)
  double family_p = 1.0; ///< the rule's number: min(1, m p) with the change point one more candidate
  double heldout_reduction = 0.0;  ///< of the held-out sum of squares with the step in the model
  double t_first = 0.0;  ///< [s] first and last sample time of the log (for the split commands)
  double t_last = 0.0;
};

/// One line: "the payload changed at t = 5.02 ± 0.03 s: mass +0.61 ± 0.01 kg, ...".
std::string describeChangePoint(const ChangePoint& cp);

/// The commands for the segments the log splits into at the change points `cps` (increasing t;
/// shell-quoted, `log_cmd` already quoted): one more than there are change points, e.g. for one
/// "ftid analyze run.csv --t-to 5.02 --model paper" and "... --t-from 5.02 ...", for two the
/// middle one "... --t-from 4.00 --t-to 6.00 ...".
std::vector<std::string> segmentCommands(const std::vector<ChangePoint>& cps, const std::string& log_cmd,
                                         const std::string& model);

/// Whether the second change point undoes the first (a description for the report, not a test):
/// the same kind, some step of the first beyond 3 of its standard errors, and what is left of it
/// after the second, |first + second|, at most half of |first| (each step in units of the first's
/// standard errors). Not "within the errors": a contact pushes in the world and turns in the
/// sensor's frame as the arm moves, so its two steps differ by more than their errors.
bool undoes(const ChangePoint& first, const ChangePoint& second);

/// `--t-from`, `--t-to`: keeps the samples with t_from <= t < t_to (t: seconds since the log's
/// first sample, as every time the laboratory prints). Throws DataError naming `log` and the span
/// when no sample is left; the too-few check is the analysis' own.
void applyTimeWindow(samples::ContextSet& set, double t_from, double t_to, const std::string& log);

}  // namespace ftid::lab
