#pragma once
// Extra log columns as candidate signals of the laboratory (docs/analyze.md, "Extra columns as
// candidate signals"): every numeric extra column that is not bookkeeping is a signal of the
// residual correlations and of two candidates, payload(<column>) (payload mass and centre of mass
// moving with it) and poly(<column>,1) (offsets linear in it). Private to ftid_lab.
#include <string>
#include <vector>

#include "ftid/lab/analyze.hpp"

namespace ftid::lab::detail {

/// At most this many extra columns become candidate signals (each brings two candidates into the
/// family of the decision rule); the rest are named in a warning.
constexpr int kMaxExtraSignals = 8;

struct ExtraSignals {
  std::vector<std::string> names;     ///< columns taken as signals, in log order
  std::vector<std::string> left_out;  ///< signal columns beyond kMaxExtraSignals
  /// Varying columns whose names cannot be an effect's argument (not letters, digits, '_', '.'; or
  /// the name of a built-in signal such as t or q1, which the signal would mean instead).
  std::vector<std::string> unnamable;
};

/// True if `name` can be written as a signal in an effect: letters, digits, '_' and '.', starting
/// with a letter or '_', and not a built-in signal's name.
bool isSignalName(const std::string& name);

/// True for columns that describe the recording, not the cell: host_time, pose, timestamps,
/// counters, robot states, stored kinematics (kin_*), pose columns (px..rz, qx..qw), commanded and
/// target joints, the simulator's contact truth (contact_*).
bool isBookkeepingColumn(const std::string& name);

/// The extra columns of `ctx` that can be signals: not bookkeeping, finite in every sample and not
/// constant. Empty when the samples carry no extra columns.
ExtraSignals extraSignals(const std::vector<SampleContext>& ctx);

/// The candidates of each signal: payload(s) and poly(s,1).
std::vector<std::string> extraSignalCandidates(const std::vector<std::string>& signals);

/// The menu with the candidates of the extra signals appended, when the user named no candidates
/// (options.candidates empty); the registry's bare "payload" (it needs a signal) is dropped. A
/// warning names the columns left out (beyond kMaxExtraSignals, or unnamable).
std::vector<std::string> withExtraSignals(std::vector<std::string> menu, const AnalyzeOptions& options,
                                          const std::vector<SampleContext>& ctx, std::vector<std::string>* warnings);

}  // namespace ftid::lab::detail
