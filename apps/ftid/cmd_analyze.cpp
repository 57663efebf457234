// `ftid analyze`: the model laboratory (docs/analyze.md).
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
#include "input_flags.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/lab/analyze.hpp"
#include "mount_option.hpp"

namespace {

const char* const kUsage =
    "usage: ftid analyze LOG [--model M] [--validate LOG2] [--folds K] [--explain]\n"
    "                        [--candidates E1,E2,...] [--report report.html] [--json] [--robot URDF]\n"
    "                        [--wrench-frame sensor|base] [--mount-rpy R,P,Y] [--config ftidd.yaml]\n"
    "                        [--wrench-log FILE] [--qdd-source diff|target] [--rated-range fz=L,..]\n"
    "                        [--t-from S] [--t-to S] [--max-rows N]\n"
    "\n"
    "Compares a model of the sensor reading with the measurements, shows where it fails and which\n"
    "physical effect is missing (docs/analyze.md; the effects: docs/effects.md).\n"
    "\n"
    "  LOG               the CSV log or a UR RTDE recording or ROS 2 bag (docs/log-format.md)\n"
    "  --model M         starting model (default 'paper' = offsets+gravity+tilt+linear_inertia);\n"
    "                    compose with '+', e.g. paper+rigid_body+cable or paper+harmonic(q6,2)\n"
    "  --validate LOG2   fit on LOG, evaluate on LOG2 (default: K-fold over contiguous time blocks)\n"
    "  --folds K         number of blocks for the K-fold validation (default 5)\n"
    "  --explain         walk to the model the rule supports: remove any effect it does not\n"
    "                    support, add the best recommended one, until neither moves (the same end\n"
    "                    from any starting model), printing the held-out residual at each step\n"
    "  --candidates L    comma-separated effects to try (default: every named effect not in the\n"
    "                    model plus harmonic(q4..q6,1), poly(t,2), poly(temp,2))\n"
    "                    plus payload(C) and poly(C,1) for each extra log column C, e.g. grip;\n"
    "                    your own effect as an expression: 'expr(fz: grip*qd6)' (docs/effects.md)\n"
    "  --noise fx=S,fy=S,fz=S,tx=S,ty=S,tz=S\n"
    "                    the sensor's noise std per axis from its data sheet [N, Nm] instead of the\n"
    "                    estimate from the data (needed for static pose sets with one reading a pose)\n"
    "  --glitch-sigma K  leave out isolated samples beyond K robust standard deviations (default 6;\n"
    "                    0 = keep every sample)\n"
    "  --max-delay S     search range of sensor_delay's delay, +-S seconds (default 1)\n"
    "  --rated-range fz=L,..\n"
    "                    the sensor's rated range per axis [N, Nm] (fx fy fz tx ty tz; axes not named\n"
    "                    have none): samples with |reading| >= L are saturated. Flat tops (an axis\n"
    "                    piled up on its extreme value) are found without it. Saturated samples are\n"
    "                    left out of every fit and reported (docs/analyze.md, \"Saturation\")\n"
    "  --alpha A         family-wise significance level of one ranking (default 0.001): an effect is\n"
    "                    recommended when min(1, m p) is below A, p = the chance that the effect\n"
    "                    predicts the held-out blocks this much better by noise alone, m = the menu's\n"
    "                    effects the data can show (one m per analysis, whatever --model), and its fit\n"
    "                    is identifiable and physical (docs/analyze.md, \"The verdict\")\n"
    "  --report FILE     write a self-contained HTML report (inline SVG; opens offline)\n"
    "  --json            print one JSON object (model, residual_rms, noise_floor, candidates, steps)\n"
    "  --wrench-frame F  frame of the log's wrench columns: sensor (default) or base (rotated into\n"
    "                    the robot base B, moments about the S origin; docs/log-format.md)\n"
    "  --config FILE     ftidd configuration: its sensor mount (X_FS) builds the kinematics\n"
    "  --mount-rpy R,P,Y the sensor's orientation in the flange frame, R_FS = Rz(Y) Ry(P) Rx(R) [rad]\n"
    "                    (default: the --config file's sensor mount, else the identity), e.g.\n"
    "                    --mount-rpy 0,0,1.5708 for a sensor mounted turned 90 deg about z\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --t-from S, --t-to S\n"
    "                    analyse only LOG's samples with S_from <= t < S_to (seconds since its first\n"
    "                    sample, as every time the report prints); a change in time (a payload grasped\n"
    "                    or released, a sensor re-bias) is reported first with the two commands that\n"
    "                    split the log there (docs/analyze.md, \"Change points\")\n"
    "%INPUT%"
    "%MAX_ROWS%"
    "  (--wrench-log applies to LOG; a --validate log is read on its own)\n"
    "\n"
    "The noise floor is detected from the data (white, coloured, static pose set, or not observable)\n"
    "and named in the report; standard errors and tests account for correlated noise. One rule gives\n"
    "each candidate its verdict (recommended, not significant, no held-out gain, refused: reason):\n"
    "significance decides; a fit that is not identifiable or not physical is refused with the reason.\n"
    "Suggested commands are shell-quoted and can be pasted.\n"
    "The last model's residual spectrum and autocorrelation are shown per axis against the noise\n"
    "model, with the motion's band; \"peak\" only beyond chance (docs/analyze.md). A filter of the\n"
    "reading (mount_dynamics: a compliant mount; sensor_filter) is searched and reported as a\n"
    "diagnosis, not compensated (docs/effects.md, \"Dynamics of the reading\").\n"
    "Every residual printed is held out. Progress goes to stderr. Exit code 1 with a one-line\n"
    "reason on a bad log or a model the data cannot determine, 2 on a usage error.\n"
    "\n"
    "Before the analysis the set-up is checked against the kinematics (docs/identification.md\n"
    "\"Set-up diagnosis\"): a wrench frame that fits better as base, a mount that fits better rotated\n"
    "(the 24 axis-aligned rotations), degrees in the angle columns; a finding is one line on stderr\n"
    "with the fix (--wrench-frame base, --mount-rpy R,P,Y).";

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (char c : s) {
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if (c == ',' && depth == 0) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

const std::string& usage() {
  static const std::string text =
      ftid::cli::withMaxRowsHelp(ftid::cli::withInputFlagsHelp(kUsage), ftid::lab::kDefaultAnalyzeMaxRows, "2 GB");
  return text;
}

int runAnalyze(const std::vector<std::string>& argv) {
  namespace cli = ftid::cli;
  ftid::lab::AnalyzeFilesRequest req;
  req.options.model = "paper";
  req.options.folds = 5;
  req.options.family_alpha = 0.001;
  req.options.glitch_threshold = 6.0;
  req.options.max_delay_s = 1.0;
  std::string candidates, noise, report, wrench_frame;
  bool json = false;
  CLI::App app{"ftid analyze"};
  app.add_option("--model", req.options.model);
  app.add_option("--validate", req.validate_path);
  app.add_option("--folds", req.options.folds)->transform(cli::integer(2, 50));
  app.add_flag("--explain", req.options.explain);
  app.add_option("--candidates", candidates);
  app.add_option("--alpha", req.options.family_alpha)->transform(cli::real({0.0, 1.0, true, true}));
  app.add_option("--noise", noise);
  app.add_option("--glitch-sigma", req.options.glitch_threshold)->transform(cli::real({0.0, 1e6, false, true}));
  app.add_option("--max-delay", req.options.max_delay_s)->transform(cli::real({0.0, 10.0, true, false}));
  app.add_option("--report", report);
  std::string rated_range;  // saturation (issue 22)
  app.add_option("--rated-range", rated_range);
  app.add_flag("--json", json);
  app.add_option("--robot", req.robot_urdf);
  app.add_option("--t-from", req.t_from)->transform(cli::real({-1e12, 1e12, true, true}));
  app.add_option("--t-to", req.t_to)->transform(cli::real({-1e12, 1e12, true, true}));
  app.add_option("--wrench-frame", wrench_frame)->transform(cli::oneOf({"sensor", "base"}));
  std::string mount_rpy, config;
  app.add_option("--mount-rpy", mount_rpy);
  app.add_option("--config", config);
  app.add_option("LOG", req.log_path);
  cli::InputFlags input;
  cli::addInputFlags(app, input);
  std::size_t max_rows = ftid::lab::kDefaultAnalyzeMaxRows;
  cli::addMaxRows(app, max_rows);
  cli::parse(app, argv);
  cli::applyInputFlags(input, req.context.input);
  req.context.input.max_rows = max_rows;
  if (req.log_path.empty()) throw cli::UsageError("exactly one LOG is required");
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(wrench_frame);
  ftid::cli::applyMount(req.context, mount_rpy, config);
  if (!noise.empty()) {
    try {
      req.options.noise_std = ftid::identify::parseNoiseSpec(noise, "--noise");
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  if (!rated_range.empty()) {  // saturation (issue 22)
    try {
      req.options.saturation.rated_range = ftid::identify::parseRatedRange(rated_range);
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  if (!report.empty()) ftid::checkOutputPath(report);  // before the work
  if (!candidates.empty()) req.options.candidates = splitList(candidates);
  req.options.progress = [](const std::string& line) { std::cerr << "ftid analyze: " << line << "\n"; };
  const ftid::lab::AnalysisResult result = ftid::lab::analyzeRecordings(req);
  if (!report.empty()) {
    ftid::lab::writeTextFileAtomically(report, ftid::lab::renderHtml(result));
    std::cerr << "ftid analyze: report written to " << report << "\n";
  }
  std::cout << (json ? ftid::lab::formatJson(result) : ftid::lab::formatText(result));
  return 0;
}

ftid::cli::Registrar reg{{"analyze", "compare a model with a log, find and rank the missing effects", usage(),
                          &runAnalyze}};

}  // namespace
