// The nonlinear search of fitModel (fit_steps.hpp): variable projection on phi (tilt, mounting,
// delay), the linear solve at each phi, Levenberg-damped Gauss-Newton, the delay's start and
// window, the axis weights and the passes of the effects that read the modelled wrench.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "fit_steps.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify::internal {

namespace {

/// Variable-projection residual for the nonlinear parameters.
LinearSolution projectedResidual(const Problem& pb, const NonlinearParams& nl, const Vec6& w,
                                 const Eigen::VectorXd& yw, Eigen::MatrixXd* A) {
  if (pb.reads_wmodel && pb.gn_theta.size() == pb.p) {
    Eigen::VectorXd shift;
    pb.buildRegressor(nl, w, A, true, &shift);
    if (!(pb.gn_lambda > 0.0)) return solveLinear(*A, yw + shift);
    // Damped step: [A; sqrt(lambda) D] theta = [y + shift; sqrt(lambda) D theta0], D = column norms.
    const Eigen::Index rows = A->rows();
    const Eigen::VectorXd d = A->colwise().norm().transpose().cwiseMax(1e-300) * std::sqrt(pb.gn_lambda);
    Eigen::MatrixXd Aa(rows + pb.p, pb.p);
    Aa.topRows(rows) = *A;
    Aa.bottomRows(pb.p) = d.asDiagonal();
    Eigen::VectorXd ya(rows + pb.p);
    ya.head(rows) = yw + shift;
    ya.tail(pb.p) = d.cwiseProduct(pb.gn_theta);
    return solveLinear(Aa, ya);
  }
  pb.buildRegressor(nl, w, A);
  return solveLinear(*A, yw);
}

/// Levenberg-damped Gauss-Newton on phi minimising the projected residual. With a delay, steps
/// stay inside [delay_lo, delay_hi] (the window the active samples were chosen for).
LinearSolution fitNonlinear(const Problem& pb, const PhiLayout& L, const Vec6& w, int max_iterations,
                            PhiState* st, double delay_lo = -1e300, double delay_hi = 1e300,
                            const GravityCompression* gc = nullptr) {
  const Eigen::VectorXd yw = gc != nullptr ? Eigen::VectorXd() : pb.weightedMeasurement(w);
  Eigen::MatrixXd A;
  auto project = [&](const NonlinearParams& nl) {
    return gc != nullptr ? gc->solve(nl, w) : projectedResidual(pb, nl, w, yw, &A);
  };
  LinearSolution cur = project(st->params(L));
  const int k = L.size;
  if (k == 0) return cur;
  double cost = cur.residual.squaredNorm();
  double lambda = 1e-6;
  for (int it = 0; it < max_iterations; ++it) {
    st->iterations = it + 1;
    Eigen::MatrixXd J(cur.residual.size(), k);
    for (int j = 0; j < k; ++j) {
      PhiState t = *st;
      t.phi(j) += L.step(j);
      J.col(j) = (project(t.params(L)).residual - cur.residual) / L.step(j);
    }
    const Eigen::VectorXd jn = J.colwise().norm();
    if (!(jn.minCoeff() > 0.0)) break;
    bool accepted = false;
    for (int attempt = 0; attempt < 12 && !accepted; ++attempt) {
      // Damped step from the augmented least-squares problem [J; sqrt(lambda) D] d = [-r; 0].
      Eigen::MatrixXd Ja(J.rows() + k, k);
      Ja.topRows(J.rows()) = J;
      Ja.bottomRows(k) = (std::sqrt(lambda) * jn).asDiagonal();
      Eigen::VectorXd ra = Eigen::VectorXd::Zero(J.rows() + k);
      ra.head(J.rows()) = -cur.residual;
      Eigen::VectorXd step = Ja.householderQr().solve(ra);
      PhiState trial_state = *st;
      trial_state.phi += step;
      if (L.delay >= 0) trial_state.phi(L.delay) = std::clamp(trial_state.phi(L.delay), delay_lo, delay_hi);
      step = trial_state.phi - st->phi;
      LinearSolution trial = project(trial_state.params(L));
      const double trial_cost = trial.residual.squaredNorm();
      if (trial_cost <= cost) {
        st->phi = trial_state.phi;
        cur = std::move(trial);
        const double old_cost = cost;
        cost = trial_cost;
        lambda = std::max(lambda * 0.1, 1e-12);
        accepted = true;
        if (step.norm() < 1e-13 || old_cost - cost <= 1e-15 * old_cost) return cur;
      } else if (step.norm() < kStepConverged) {
        // At the minimum the cost changes only by rounding and a step is as likely to be rejected
        // as accepted: stop instead of re-solving with ever more damping (up to 12 solves).
        return cur;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) break;
  }
  return cur;
}

/// Sets the delay's window around center (FitState::delay_lo, delay_hi) and the samples that stay
/// inside the data for every delay in it.
void setDelayWindow(FitState& f, double center) {
  const double margin = std::max(0.02 * f.options.max_delay_s, 4.0 * f.dt_mean);
  f.delay_lo = std::max(-f.options.max_delay_s, center - margin);
  f.delay_hi = std::min(f.options.max_delay_s, center + margin);
  f.pb.setActiveWindow(f.delay_lo, f.delay_hi);
  if (6 * f.pb.n_active < f.n_unknowns + 1) {
    throw IdentificationError("a delay of " + std::to_string(center) + " s leaves too few samples (" +
                              std::to_string(f.pb.n_active) + ") inside the log");
  }
}

/// Weighted sum of squares of the true model (effects::ModelEvaluator) over the active samples.
double trueCost(const FitState& f, const Eigen::VectorXd& theta, const NonlinearParams& nl) {
  const Mat6X r = f.measured - f.pb.predict(theta, nl);
  double sse = 0.0;
  for (int i = 0; i < f.pb.n; ++i) {
    if (f.pb.active[static_cast<std::size_t>(i)]) sse += f.weights.cwiseProduct(r.col(i)).squaredNorm();
  }
  return sse;
}

/// Levenberg-damped Gauss-Newton passes on the modelled-wrench effects (Problem::gn_theta) after
/// fitNonlinear, each accepted only if the true (bilinear) model's cost falls; then the
/// linearisation is left at the solution, undamped (the Jacobian and covariance use it), and
/// f.sol's residual is the true model's.
void modelWrenchPasses(FitState& f, int derivative_passes, int iterations) {
  Problem& pb = f.pb;
  const PhiLayout& L = f.L;
  double cost = trueCost(f, f.sol.theta, f.st.params(L));
  double lambda = 1e-4;
  for (int k = 0; k < 4 * derivative_passes && lambda < 1e8; ++k) {
    const LinearSolution saved_sol = f.sol;
    const PhiState saved_st = f.st;
    pb.wmodel = pb.basePrediction(f.sol.theta, f.st.params(L));
    pb.gn_theta = f.sol.theta;
    pb.gn_lambda = lambda;
    // The passes themselves iterate: a couple of nonlinear steps per pass suffice.
    f.sol = fitNonlinear(pb, L, f.weights, std::min(iterations, 2), &f.st, f.delay_lo, f.delay_hi);
    const double trial = trueCost(f, f.sol.theta, f.st.params(L));
    if (trial <= cost) {
      const double change = cost - trial;
      cost = trial;
      lambda = std::max(lambda * 0.1, 1e-12);
      if (change <= 1e-10 * cost) break;
    } else {
      f.sol = saved_sol;
      f.st = saved_st;
      lambda *= 10.0;
    }
  }
  pb.wmodel = pb.basePrediction(f.sol.theta, f.st.params(L));
  pb.gn_theta = f.sol.theta;
  pb.gn_lambda = 0.0;
  Eigen::VectorXd r(6 * pb.n);
  const Mat6X m = pb.predict(f.sol.theta, f.st.params(L));
  for (int i = 0; i < pb.n; ++i) {
    r.segment<6>(6 * i) = pb.active[static_cast<std::size_t>(i)]
                              ? Vec6(f.weights.cwiseProduct(f.measured.col(i) - m.col(i)))
                              : Vec6::Zero();
  }
  f.sol.residual = r;
}

/// One fit at the current weights and delay window: the nonlinear search, then (models that read
/// the modelled wrench) derivative_passes rounds of modelWrenchPasses.
void runFit(FitState& f, int derivative_passes, int iterations) {
  f.pb.gn_lambda = 0.0;
  f.sol = fitNonlinear(f.pb, f.L, f.weights, iterations, &f.st, f.delay_lo, f.delay_hi, f.gcp());
  if (derivative_passes == 0) return;
  modelWrenchPasses(f, derivative_passes, iterations);
}

/// The delay's start: fit everything else with no delay, then scan the delay on that prediction
/// (initialDelayEstimate) and centre the window on it.
void startDelay(FitState& f) {
  Problem& pb = f.pb;
  f.st.phi(f.L.delay) = 0.0;
  f.delay_lo = f.delay_hi = 0.0;
  pb.setActiveWindow(0.0, 0.0);
  runFit(f, pb.reads_wmodel ? 1 : 0, std::min(f.options.max_tilt_iterations, 4));
  const Mat6X r0 = unstack(f.sol.residual, pb.n);
  Vec6 w0 = Vec6::Ones();
  const Vec6 rms0 = (r0.rowwise().squaredNorm() / pb.n).cwiseSqrt();
  const double fl0 = std::max(1e-3 * rms0.maxCoeff(), 1e-12);
  for (int a = 0; a < 6; ++a) w0(a) = 1.0 / std::max(rms0(a), fl0);
  const Mat6X pred0 = pb.predict(f.sol.theta, f.st.params(f.L));
  std::vector<double> times(static_cast<std::size_t>(pb.n));
  for (int i = 0; i < pb.n; ++i) times[static_cast<std::size_t>(i)] = pb.at(i).t;
  const double tau0 = initialDelayEstimate(times, f.measured, pred0, w0, f.options.max_delay_s);
  f.st.phi(f.L.delay) = tau0;
  setDelayWindow(f, tau0);
}

/// The axis weights from the residual of the unweighted pass: 1 / RMS per axis, floored at 1e-3
/// of the largest. Compressed: the per-axis sums of squares from the factor
/// (GravityCompression::residualSquares).
void setAxisWeights(FitState& f) {
  const Problem& pb = f.pb;
  const Vec6 ss = f.compressed ? f.gc.residualSquares(model::gravityInBase(f.st.params(f.L).tilt_u_rad,
                                                                            f.st.params(f.L).tilt_v_rad),
                                                      f.sol.theta)
                               : Vec6(unstack(f.sol.residual, pb.n).rowwise().squaredNorm());
  const Vec6 rms = (ss / std::max(1, pb.n_active)).cwiseSqrt();
  const double floor = std::max(1e-3 * rms.maxCoeff(), 1e-12);
  for (int a = 0; a < 6; ++a) f.weights(a) = 1.0 / std::max(rms(a), floor);
}

}  // namespace

void searchNonlinear(FitState& f) {
  const FitOptions& options = f.options;
  Problem& pb = f.pb;
  f.dt_mean = pb.n > 1 ? (pb.at(pb.n - 1).t - pb.at(0).t) / (pb.n - 1) : 0.0;
  if (pb.delay) startDelay(f);
  // The unweighted pass only has to give the per-axis residual RMS for the weights: a few
  // iterations suffice; the weighted pass then converges fully from there.
  runFit(f, pb.reads_wmodel ? options.derivative_iterations : 0,
         options.axis_weights ? std::min(options.max_tilt_iterations, 4) : options.max_tilt_iterations);
  if (options.axis_weights) {
    setAxisWeights(f);
    runFit(f, pb.reads_wmodel ? 2 : 0, options.max_tilt_iterations);
  }
  // A delay that ran into its window's edge: move the window and refit (a few times at most).
  for (int k = 0; pb.delay && k < 3; ++k) {
    const double tau = f.st.phi(f.L.delay);
    const bool at_edge = (tau <= f.delay_lo + 1e-12 && f.delay_lo > -options.max_delay_s) ||
                         (tau >= f.delay_hi - 1e-12 && f.delay_hi < options.max_delay_s);
    if (!at_edge) break;
    setDelayWindow(f, tau);
    runFit(f, pb.reads_wmodel ? 2 : 0, options.max_tilt_iterations);
  }
}

}  // namespace ftid::identify::internal
