#pragma once
// The change-point scan of the model laboratory (include/ftid/lab/change_point.hpp,
// docs/analyze.md "Change points"). Private to ftid_lab.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ftid/fileio/json_text.hpp"
#include "ftid/lab/change_point.hpp"
#include "ftid/lab/dynamics.hpp"
#include "lab_internal.hpp"

namespace ftid::lab::detail {

/// Why no change point is reported (one line; "" when none was scanned) and the scan's p-value.
struct ScanNote {
  std::string why;
  double p_scan = 1.0;
};

/// The change points of the fitting log against `base`: none, the best one (a payload or offsets
/// step), or that one and a second change of the same kind after it (binary segmentation: a
/// contact that ends, an object held for a while). Each is judged by the rule (lab/verdict.hpp)
/// as one more candidate of the family; they are kept only when the model with their steps lowers
/// the held-out error more than `best_smooth_reduction` (the best smooth candidate's whose gain is
/// significant, recommended or refused: a step must explain the data better than the effects that
/// would imitate it). `note` (may be
/// null): the scan's p-value and, when none is reported, why.
std::vector<ChangePoint> findChangePoints(const RankContext& rc, const Fitted& base, double best_smooth_reduction,
                                          ScanNote* note);

/// The smooth model --explain reaches from `base` (its name) and its held-out reduction against base.
struct SmoothPath {
  std::string model;
  double heldout_reduction = 0.0;
};

/// analyze()'s call: scans against `base` with the ranking's best significant reduction, fills
/// result.change_points and a warning, and says why none was reported in a progress line. When
/// steps would be reported, `reading_dynamics` (if set) searches the dynamics of the reading on
/// `base`, and `smooth_path` (if set: with --explain) walks the path without change points; either
/// lowering the held-out error more than the steps wins, and none is reported (a compliant mount's
/// lag beside a temperature drift reads as two offsets steps against `paper`, where rigid_body is
/// refused until the lag is modelled: no single effect beats the steps, the path's end does).
void reportChangePoints(const RankContext& rc, const Fitted& base, AnalysisResult& result,
                        const std::function<DynamicsCheck()>& reading_dynamics = {},
                        const std::function<SmoothPath()>& smooth_path = {});

/// The report blocks (change_point_report.cpp); "" / nothing when there is no change point.
std::string changePointText(const AnalysisResult& r);
std::string changePointHtml(const AnalysisResult& r);
void addChangePointsJson(const AnalysisResult& r, nlohmann::ordered_json& o);

}  // namespace ftid::lab::detail
