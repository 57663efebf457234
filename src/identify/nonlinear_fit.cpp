// The fitting core's nonlinear step on stacked, treated data (ftid/identify/nonlinear_fit.hpp).
#include "ftid/identify/nonlinear_fit.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/normal_equations.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify {

namespace {

using effects::Model;

constexpr int kMaxPasses = 30;              // Gauss-Newton passes of fit()
constexpr double kStepConverged = 1e-9;     // [rad, s] largest nonlinear step at convergence
constexpr double kDerivedConverged = 1e-6;  // relative change of the derived signals at convergence
constexpr double kMountStep = 1e-5;         // [rad] central-difference step of the mounting columns

/// d g_B / dU and d g_B / dV (docs/conventions.md: g_B = g (cosU sinV, -sinU, -cosU cosV)).
Vec3 gravityDerivativeU(double u, double v) {
  return kStandardGravity * Vec3(-std::sin(u) * std::sin(v), -std::cos(u), std::sin(u) * std::cos(v));
}
Vec3 gravityDerivativeV(double u, double v) {
  return kStandardGravity * Vec3(std::cos(u) * std::cos(v), 0.0, std::cos(u) * std::sin(v));
}

}  // namespace

Mat6X exclusionWeights(const std::vector<char>& excluded, const Vec6& ar1, const std::vector<int>& filter_start,
                       int n) {
  Mat6X w = Mat6X::Ones(6, n);
  std::vector<int> starts = filter_start.empty() ? std::vector<int>{0} : filter_start;
  starts.push_back(n);
  for (std::size_t r = 0; r + 1 < starts.size(); ++r) {
    for (int i = starts[r]; i < starts[r + 1]; ++i) {
      if (static_cast<std::size_t>(i) >= excluded.size() || !excluded[static_cast<std::size_t>(i)]) continue;
      for (int a = 0; a < 6; ++a) {
        w(a, i) = 0.0;
        if (ar1(a) != 0.0 && i + 1 < starts[r + 1]) w(a, i + 1) = 0.0;
      }
    }
  }
  return w;
}

NonlinearFit::NonlinearFit(std::vector<SampleContext> contexts, DataTreatment treatment)
    : ctx_(std::move(contexts)), tr_(std::move(treatment)) {
  const int n = size();
  n_fit_ = tr_.n_fit < 0 ? n : tr_.n_fit;
  if (n_fit_ > n) {
    throw std::invalid_argument("NonlinearFit: " + std::to_string(n_fit_) + " fitting samples of " + std::to_string(n));
  }
  if (tr_.row_weights.cols() != 0 && tr_.row_weights.cols() != n) {
    throw std::invalid_argument("NonlinearFit: row weights for " + std::to_string(tr_.row_weights.cols()) +
                                " samples, data have " + std::to_string(n));
  }
  std::vector<int> starts = tr_.filter_start.empty() ? std::vector<int>{0} : tr_.filter_start;
  if (starts.front() != 0) throw std::invalid_argument("NonlinearFit: the first filter run must start at sample 0");
  bool fit_boundary = n_fit_ == n;
  for (std::size_t r = 0; r < starts.size(); ++r) {
    const int end = r + 1 < starts.size() ? starts[r + 1] : n;
    if (end <= starts[r] || end > n) {
      throw std::invalid_argument("NonlinearFit: filter run " + std::to_string(r) + " [" + std::to_string(starts[r]) +
                                  ", " + std::to_string(end) + ") is empty or outside the data");
    }
    runs_.emplace_back(starts[r], end);
    fit_boundary = fit_boundary || starts[r] == n_fit_;
  }
  if (!fit_boundary) {
    throw std::invalid_argument("NonlinearFit: the fitting samples must end at a filter run boundary");
  }
  run_of_.assign(static_cast<std::size_t>(n), 0);
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    for (int i = runs_[r].first; i < runs_[r].second; ++i) run_of_[static_cast<std::size_t>(i)] = static_cast<int>(r);
  }
  times_.reserve(ctx_.size());
  for (const auto& c : ctx_) times_.push_back(c.t);
}

int NonlinearFit::segmentOf(int i) const {
  const auto& st = tr_.segment_start;
  int seg = 0;
  for (std::size_t k = 0; k < st.size(); ++k) {
    if (st[k] <= i) seg = static_cast<int>(k);
  }
  return seg;
}

SampleContext NonlinearFit::prepare(int i, const Linearization& lin, const Vec3& g_B, const Mat3& R_SM) const {
  SampleContext c = ctx_[static_cast<std::size_t>(i)];
  if (lin.delay != 0.0) {
    // The kinematics at t - delay, interpolated within this sample's own log (nearest end outside).
    const int seg = segmentOf(i);
    const auto& st = tr_.segment_start;
    const int begin = st.empty() ? 0 : st[static_cast<std::size_t>(seg)];
    const int end = static_cast<std::size_t>(seg + 1) < st.size() ? st[static_cast<std::size_t>(seg + 1)] : size();
    auto at = [&](int k) -> const SampleContext& { return ctx_[static_cast<std::size_t>(begin + k)]; };
    const int n = end - begin;
    const double ts = std::clamp(c.t - lin.delay, at(0).t, at(n - 1).t);
    effects::kinematicsAt(at, n, ts, &c);
  }
  if (lin.mount.squaredNorm() > 0.0) effects::applyMounting(R_SM, &c);
  c.g_S = c.R_BS.transpose() * g_B;
  return c;
}

void NonlinearFit::updateActive(Linearization& lin) const {
  lin.active.clear();
  if (lin.delay == 0.0) return;
  lin.active.assign(static_cast<std::size_t>(size()), 1);
  std::vector<int> starts = tr_.segment_start;
  if (starts.empty()) starts.push_back(0);
  starts.push_back(size());
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    const double t0 = times_[static_cast<std::size_t>(starts[s])];
    const double t1 = times_[static_cast<std::size_t>(starts[s + 1] - 1)];
    for (int i = starts[s]; i < starts[s + 1]; ++i) {
      const double ts = times_[static_cast<std::size_t>(i)] - lin.delay;
      lin.active[static_cast<std::size_t>(i)] = (ts >= t0 - 1e-9 && ts <= t1 + 1e-9) ? 1 : 0;
    }
  }
}

SampleContext NonlinearFit::contextAt(int i, const Linearization& lin) const {
  SampleContext c = prepare(i, lin, model::gravityInBase(lin.u, lin.v), effects::mountingRotation(lin.mount));
  if (lin.w_model.cols() == size()) {
    c.wrench_model_S = lin.w_model.col(i);
  } else {
    c.wrench_model_S.setZero();
  }
  return c;
}

int NonlinearFit::rowOf(int i, int a) const {
  const auto& run = runs_[static_cast<std::size_t>(run_of_[static_cast<std::size_t>(i)])];
  return 6 * run.first + a * (run.second - run.first) + (i - run.first);
}

NonlinearFit::Design NonlinearFit::design(const Model& model, const Linearization& lin) const {
  Design X = rawDesign(model, lin);
  whiten(X, 0, static_cast<int>(X.cols()));
  return X;
}

void NonlinearFit::whiten(Design& X, int c0, int c1) const {
  const int nc = c1 - c0;
  if (nc <= 0) return;
  const bool row_weighted = tr_.row_weights.cols() == size();
  for (const auto& [begin, end] : runs_) {
    const int nr = end - begin;
    for (int a = 0; a < 6; ++a) {
      const double phi = tr_.ar1(a);
      const std::ptrdiff_t r0 = 6 * static_cast<std::ptrdiff_t>(begin) + static_cast<std::ptrdiff_t>(a) * nr;
      if (phi != 0.0) {
        for (int i = nr - 1; i >= 1; --i) X.row(r0 + i).segment(c0, nc) -= phi * X.row(r0 + i - 1).segment(c0, nc);
        X.row(r0).segment(c0, nc) *= std::sqrt(1.0 - phi * phi);
      }
      if (!row_weighted) continue;
      for (int i = 0; i < nr; ++i) {
        const double w = tr_.row_weights(a, begin + i);
        if (w == 0.0) {
          X.row(r0 + i).segment(c0, nc).setZero();
        } else if (w != 1.0) {
          X.row(r0 + i).segment(c0, nc) *= w;
        }
      }
    }
  }
}

NonlinearFit::Design NonlinearFit::rawDesign(const Model& model, const Linearization& lin) const {
  const int n = size();
  const int p = model.numParams();
  const int pt = p + lin.extraColumns();
  Design X(6 * n, pt + 1);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  const Vec3 g_B = model::gravityInBase(lin.u, lin.v);
  const Mat3 R_SM = effects::mountingRotation(lin.mount);
  const bool has_derived = lin.w_model.cols() == n;
  const bool masked = lin.active.size() == static_cast<std::size_t>(n);
  const Vec6& w = tr_.axis_weights;
  const int mc = lin.mountColumn(p);
  const int dc = lin.delayColumn(p);
  SampleContext c;
  for (int i = 0; i < n; ++i) {
    if (masked && !lin.active[static_cast<std::size_t>(i)]) {
      for (int a = 0; a < 6; ++a) {
        double* row = X.data() + static_cast<std::ptrdiff_t>(rowOf(i, a)) * (pt + 1);
        std::fill(row, row + pt + 1, 0.0);
      }
      continue;
    }
    c = prepare(i, lin, g_B, R_SM);
    if (has_derived) {
      c.wrench_model_S = lin.w_model.col(i);
    } else {
      c.wrench_model_S.setZero();
    }
    model.computeRegressor(c, Y);
    for (int a = 0; a < 6; ++a) {
      double* row = X.data() + static_cast<std::ptrdiff_t>(rowOf(i, a)) * (pt + 1);
      for (int k = 0; k < p; ++k) row[k] = w(a) * Y(a, k);
      if (lin.tilt_columns) {
        row[p] = w(a) * lin.j_u(a, i);
        row[p + 1] = w(a) * lin.j_v(a, i);
      }
      if (lin.mount_columns) {
        for (int k = 0; k < 3; ++k) row[mc + k] = w(a) * lin.j_m[static_cast<std::size_t>(k)](a, i);
      }
      if (lin.delay_column) row[dc] = w(a) * lin.j_d(a, i);
      row[pt] = w(a) * c.wrench_S(a);
    }
  }
  return X;
}

std::vector<SampleContext> NonlinearFit::prepared(const Linearization& lin) const {
  std::vector<SampleContext> out(ctx_.size());
  for (int i = 0; i < size(); ++i) out[static_cast<std::size_t>(i)] = contextAt(i, lin);
  return out;
}

NonlinearFit::Design NonlinearFit::designExtended(const Model& base, const Design& base_design, const Model& cand,
                                                  const Linearization& lin,
                                                  const std::vector<SampleContext>& prepared_ctx) const {
  const int pb = base.numParams();
  const int pc = cand.numParams();
  const int extra = lin.extraColumns();  // nonlinear columns, copied from the base design
  const auto& bn = base.paramIndex().names();
  const auto& cn = cand.paramIndex().names();
  bool prefix = base_design.cols() == pb + extra + 1 && pc >= pb;
  for (int k = 0; prefix && k < pb; ++k) prefix = bn[static_cast<std::size_t>(k)] == cn[static_cast<std::size_t>(k)];
  if (!prefix) return design(cand, lin);
  std::vector<const effects::Effect*> added;
  for (const auto& e : cand.effectList()) {
    if (!base.contains(e->name())) added.push_back(e.get());
  }
  const int n = size();
  // The added effects' contributions alone, filtered, then the (already filtered) base columns.
  Design X = Design::Zero(6 * n, pc + extra + 1);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, pc);
  const Vec6& w = tr_.axis_weights;
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = prepared_ctx[static_cast<std::size_t>(i)];
    Y.setZero();
    for (const auto* e : added) e->addRegressor(c, Y);
    for (int a = 0; a < 6; ++a) {
      double* row = X.data() + static_cast<std::ptrdiff_t>(rowOf(i, a)) * (pc + extra + 1);
      for (int k = 0; k < pc; ++k) row[k] = w(a) * Y(a, k);
    }
  }
  whiten(X, 0, pc);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const double* src = base_design.data() + r * (pb + extra + 1);
    double* row = X.data() + r * (pc + extra + 1);
    for (int k = 0; k < pb; ++k) row[k] += src[k];
    for (int k = 0; k <= extra; ++k) row[pc + k] = src[pb + k];
  }
  return X;
}

std::vector<std::array<Eigen::MatrixXd, 6>> NonlinearFit::runGrams(const Design& X) const {
  const Eigen::Index p1 = X.cols();
  std::vector<std::array<Eigen::MatrixXd, 6>> G(runs_.size());
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    const auto& [begin, end] = runs_[r];
    const int nr = end - begin;
    for (int a = 0; a < 6; ++a) {
      const auto rows = X.middleRows(6 * begin + a * nr, nr);
      Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p1, p1);
      g.selfadjointView<Eigen::Lower>().rankUpdate(rows.transpose());
      G[r][static_cast<std::size_t>(a)] = g.selfadjointView<Eigen::Lower>();
    }
  }
  return G;
}

Eigen::VectorXd NonlinearFit::solveFit(const Design& X) const {
  const int p = static_cast<int>(X.cols()) - 1;
  const auto G = runGrams(X);
  Eigen::MatrixXd Gf = Eigen::MatrixXd::Zero(p + 1, p + 1);
  for (std::size_t r = 0; r < runs_.size() && runs_[r].first < n_fit_; ++r) {
    // Sum per run first (the order the lab's fold solves use, so a full-data solve is the same).
    Eigen::MatrixXd Gr = Eigen::MatrixXd::Zero(p + 1, p + 1);
    for (const auto& g : G[r]) Gr += g;
    Gf += Gr;
  }
  return solveGram(Gf.topLeftCorner(p, p), Gf.col(p).head(p), false).x;
}

Mat6X NonlinearFit::predict(const Model& model, const Linearization& lin, const Eigen::VectorXd& theta,
                            bool exclude_derived) const {
  const int n = size();
  const int p = model.numParams();
  Mat6X out(6, n);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  for (int i = 0; i < n; ++i) {
    SampleContext c = contextAt(i, lin);
    if (exclude_derived) c.wrench_model_S.setZero();
    model.computeRegressor(c, Y);
    out.col(i) = Y * theta.head(p);
  }
  return out;
}

Mat6X NonlinearFit::timeDerivative(const Mat6X& w) const {
  return identify::timeDerivative(times_, w, tr_.segment_start);
}

void NonlinearFit::tiltColumns(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  const int n = size();
  const int p = model.numParams();
  lin.j_u.resize(6, n);
  lin.j_v.resize(6, n);
  const Vec3 du = gravityDerivativeU(lin.u, lin.v);
  const Vec3 dv = gravityDerivativeV(lin.u, lin.v);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  const Eigen::VectorXd th = theta.head(p);
  for (int i = 0; i < n; ++i) {
    SampleContext c = contextAt(i, lin);
    // The regressor is affine in g_S (only gravity reads it): d(Y theta)/dU = (Y(g') - Y(0)) theta.
    c.g_S.setZero();
    model.computeRegressor(c, Y);
    const Vec6 base = Y * th;
    c.g_S = c.R_BS.transpose() * du;
    model.computeRegressor(c, Y);
    lin.j_u.col(i) = Y * th - base;
    c.g_S = c.R_BS.transpose() * dv;
    model.computeRegressor(c, Y);
    lin.j_v.col(i) = Y * th - base;
  }
}

void NonlinearFit::mountColumns(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  for (int k = 0; k < 3; ++k) {
    Linearization lp = lin;
    Linearization lm = lin;
    lp.mount(k) += kMountStep;
    lm.mount(k) -= kMountStep;
    lin.j_m[static_cast<std::size_t>(k)] =
        (predict(model, lp, theta, false) - predict(model, lm, theta, false)) / (2.0 * kMountStep);
  }
}

void NonlinearFit::delayColumn(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  // d/dtau w(kinematics at t - tau) = -(dw/dt)(t - tau): minus the time derivative of the prediction.
  lin.j_d = -timeDerivative(predict(model, lin, theta, false));
}

Linearization NonlinearFit::initial(const Model& model) const {
  Linearization lin;
  if (model.estimatesTilt()) {
    std::vector<int> fit_samples(static_cast<std::size_t>(n_fit_));
    for (int i = 0; i < n_fit_; ++i) fit_samples[static_cast<std::size_t>(i)] = i;
    if (initialTilt(ctx_, fit_samples, &lin.u, &lin.v)) {
      if (std::abs(lin.u) > 0.5 || std::abs(lin.v) > 0.5) lin.u = lin.v = 0.0;  // implausible: start level
    }
  }
  // Derived signals unknown yet: zero (their columns drop out of the first solve).
  return lin;
}

void NonlinearFit::completeDerived(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  if ((model.signals() & effects::kSignalModelWrench) != 0) return;
  lin.w_model = predict(model, lin, theta, true);
  lin.dw_dt = timeDerivative(lin.w_model);
}

Linearization NonlinearFit::fit(const Model& model, const Linearization& start) const {
  Linearization lin = start;
  const int p = model.numParams();
  const bool tilt = model.estimatesTilt();
  const bool mount = model.estimatesMounting();
  const bool delay = model.estimatesDelay();
  const bool derived = (model.signals() & effects::kSignalModelWrench) != 0;
  lin.tilt_columns = false;
  lin.mount_columns = false;
  lin.delay_column = false;
  if (!mount) lin.mount.setZero();
  if (!delay) lin.delay = 0.0;
  updateActive(lin);
  Eigen::VectorXd theta = solveFit(design(model, lin)).head(p);
  if (delay && lin.delay == 0.0) {
    // Start for the delay: scan the shifted prediction of the model without delay
    // (initialDelayEstimate) on the fitting data's first log.
    const int end = tr_.segment_start.size() > 1 ? tr_.segment_start[1] : n_fit_;
    const int n0 = std::min(end, n_fit_);
    std::vector<double> t(times_.begin(), times_.begin() + n0);
    Mat6X measured(6, n0);
    for (int i = 0; i < n0; ++i) measured.col(i) = ctx_[static_cast<std::size_t>(i)].wrench_S;
    const Mat6X pred = predict(model, lin, theta, false).leftCols(n0);
    lin.delay = initialDelayEstimate(t, measured, pred, tr_.axis_weights, tr_.max_delay_s);
    updateActive(lin);
    theta = solveFit(design(model, lin)).head(p);
  }
  for (int it = 0; it < kMaxPasses; ++it) {
    double change = 0.0;
    if (derived) {
      const Mat6X w = predict(model, lin, theta, true);
      if (lin.w_model.cols() == w.cols()) {
        const double scale = std::max(1e-12, w.cwiseAbs().maxCoeff());
        change = (w - lin.w_model).cwiseAbs().maxCoeff() / scale;
      } else {
        change = 1.0;
      }
      lin.w_model = w;
      lin.dw_dt = timeDerivative(w);
    }
    double step = 0.0;
    if (tilt) {
      tiltColumns(model, lin, theta);
      lin.tilt_columns = true;
    }
    if (mount) {
      mountColumns(model, lin, theta);
      lin.mount_columns = true;
    }
    if (delay) {
      delayColumn(model, lin, theta);
      lin.delay_column = true;
    }
    const Eigen::VectorXd x = solveFit(design(model, lin));
    theta = x.head(p);
    if (tilt) {
      const double du = x(p);
      const double dv = x(p + 1);
      lin.u += du;
      lin.v += dv;
      step = std::max(std::abs(du), std::abs(dv));
    }
    if (mount) {
      const Vec3 dm = x.segment<3>(lin.mountColumn(p));
      lin.mount += dm;
      step = std::max(step, dm.cwiseAbs().maxCoeff());
    }
    if (delay) {
      const double dd = std::clamp(x(lin.delayColumn(p)), -tr_.max_delay_s - lin.delay, tr_.max_delay_s - lin.delay);
      lin.delay += dd;
      step = std::max(step, std::abs(dd));
      updateActive(lin);
    }
    if (step < kStepConverged && change < kDerivedConverged) break;
  }
  // The linearisation at the converged point: the Jacobian columns for the final solve.
  if (tilt) tiltColumns(model, lin, theta);
  if (mount) mountColumns(model, lin, theta);
  if (delay) delayColumn(model, lin, theta);
  lin.tilt_columns = tilt;
  lin.mount_columns = mount;
  lin.delay_column = delay;
  return lin;
}

}  // namespace ftid::identify
