// The fitting engine of the model laboratory (engine.hpp).
#include "engine.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>

#include "ftid/common/error.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/normal_equations.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::lab::detail {

namespace {

using effects::Model;


/// d g_B / dU and d g_B / dV (docs/conventions.md: g_B = g (cosU sinV, -sinU, -cosU cosV)).
Vec3 gravityDerivativeU(double u, double v) {
  return kStandardGravity * Vec3(-std::sin(u) * std::sin(v), -std::cos(u), std::sin(u) * std::cos(v));
}
Vec3 gravityDerivativeV(double u, double v) {
  return kStandardGravity * Vec3(std::cos(u) * std::cos(v), 0.0, std::cos(u) * std::sin(v));
}

}  // namespace

Engine::Engine(Dataset data) : data_(std::move(data)) {
  times_.reserve(data_.ctx.size());
  for (const auto& c : data_.ctx) times_.push_back(c.t);
  block_of_.assign(static_cast<std::size_t>(data_.size()), 0);
  for (std::size_t b = 0; b < data_.blocks.size(); ++b) {
    for (int i = data_.blocks[b].begin; i < data_.blocks[b].end; ++i) block_of_[static_cast<std::size_t>(i)] = static_cast<int>(b);
  }
  for (int f = 0; f < data_.foldCount(); ++f) {
    const Block& b = data_.blocks[static_cast<std::size_t>(data_.testBlock(f))];
    for (int i = b.begin; i < b.end; ++i) test_samples_.push_back(i);
  }
}

int Engine::segmentOf(int i) const {
  const auto& st = data_.segment_start;
  int seg = 0;
  for (std::size_t k = 0; k < st.size(); ++k) {
    if (st[k] <= i) seg = static_cast<int>(k);
  }
  return seg;
}

SampleContext Engine::prepare(int i, const Linearization& lin, const Vec3& g_B, const Mat3& R_SM) const {
  SampleContext c = data_.ctx[static_cast<std::size_t>(i)];
  if (lin.delay != 0.0) {
    // The kinematics at t - delay, interpolated within this sample's own log (nearest end outside).
    const int seg = segmentOf(i);
    const int begin = data_.segment_start.empty() ? 0 : data_.segment_start[static_cast<std::size_t>(seg)];
    const int end = static_cast<std::size_t>(seg + 1) < data_.segment_start.size()
                        ? data_.segment_start[static_cast<std::size_t>(seg + 1)]
                        : data_.size();
    auto at = [&](int k) -> const SampleContext& { return data_.ctx[static_cast<std::size_t>(begin + k)]; };
    const int n = end - begin;
    const double ts = std::clamp(c.t - lin.delay, at(0).t, at(n - 1).t);
    effects::kinematicsAt(at, n, ts, &c);
  }
  if (lin.mount.squaredNorm() > 0.0) effects::applyMounting(R_SM, &c);
  c.g_S = c.R_BS.transpose() * g_B;
  return c;
}

void Engine::updateActive(Linearization& lin) const {
  lin.active.clear();
  if (lin.delay == 0.0) return;
  lin.active.assign(static_cast<std::size_t>(data_.size()), 1);
  std::vector<int> starts = data_.segment_start;
  if (starts.empty()) starts.push_back(0);
  starts.push_back(data_.size());
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    const double t0 = data_.ctx[static_cast<std::size_t>(starts[s])].t;
    const double t1 = data_.ctx[static_cast<std::size_t>(starts[s + 1] - 1)].t;
    for (int i = starts[s]; i < starts[s + 1]; ++i) {
      const double ts = data_.ctx[static_cast<std::size_t>(i)].t - lin.delay;
      lin.active[static_cast<std::size_t>(i)] = (ts >= t0 - 1e-9 && ts <= t1 + 1e-9) ? 1 : 0;
    }
  }
}

SampleContext Engine::contextAt(int i, const Linearization& lin) const {
  SampleContext c = prepare(i, lin, model::gravityInBase(lin.u, lin.v), effects::mountingRotation(lin.mount));
  if (lin.w_model.cols() == data_.size()) {
    c.wrench_model_S = lin.w_model.col(i);
  } else {
    c.wrench_model_S.setZero();
  }
  return c;
}

int Engine::rowOf(int i, int a) const {
  const Block& blk = data_.blocks[static_cast<std::size_t>(block_of_[static_cast<std::size_t>(i)])];
  return 6 * blk.begin + a * (blk.end - blk.begin) + (i - blk.begin);
}

Engine::Design Engine::design(const Model& model, const Linearization& lin) const {
  Design X = rawDesign(model, lin);
  whiten(X, 0, static_cast<int>(X.cols()));
  return X;
}

void Engine::whiten(Design& X, int c0, int c1) const {
  const int nc = c1 - c0;
  if (nc <= 0) return;
  const bool any_ar = data_.ar1.cwiseAbs().maxCoeff() > 0.0;
  for (const Block& blk : data_.blocks) {
    const int nbk = blk.end - blk.begin;
    for (int a = 0; a < 6; ++a) {
      const double phi = data_.ar1(a);
      const std::ptrdiff_t r0 = 6 * static_cast<std::ptrdiff_t>(blk.begin) + static_cast<std::ptrdiff_t>(a) * nbk;
      if (phi != 0.0 && nbk > 0) {
        for (int i = nbk - 1; i >= 1; --i) {
          X.row(r0 + i).segment(c0, nc) -= phi * X.row(r0 + i - 1).segment(c0, nc);
        }
        X.row(r0).segment(c0, nc) *= std::sqrt(1.0 - phi * phi);
      }
      if (data_.excluded.empty()) continue;
      for (int i = 0; i < nbk; ++i) {
        if (!data_.excluded[static_cast<std::size_t>(blk.begin + i)]) continue;
        X.row(r0 + i).segment(c0, nc).setZero();
        if (any_ar && phi != 0.0 && i + 1 < nbk) X.row(r0 + i + 1).segment(c0, nc).setZero();
      }
    }
  }
}

Engine::Design Engine::rawDesign(const Model& model, const Linearization& lin) const {
  const int n = data_.size();
  const int p = model.numParams();
  const int pt = p + lin.extraColumns();
  Design X(6 * n, pt + 1);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  const Vec3 g_B = model::gravityInBase(lin.u, lin.v);
  const Mat3 R_SM = effects::mountingRotation(lin.mount);
  const bool has_derived = lin.w_model.cols() == n;
  const bool masked = lin.active.size() == static_cast<std::size_t>(n);
  const Vec6& w = data_.weights;
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
        for (int k = 0; k < 3; ++k) row[mc + k] = w(a) * lin.j_m[k](a, i);
      }
      if (lin.delay_column) row[dc] = w(a) * lin.j_d(a, i);
      row[pt] = w(a) * c.wrench_S(a);
    }
  }
  return X;
}

std::vector<SampleContext> Engine::prepared(const Linearization& lin) const {
  std::vector<SampleContext> out(data_.ctx.size());
  for (int i = 0; i < data_.size(); ++i) out[static_cast<std::size_t>(i)] = contextAt(i, lin);
  return out;
}

Engine::Design Engine::designExtended(const Model& base, const Design& base_design, const Model& cand,
                                      const Linearization& lin, const std::vector<SampleContext>& prepared_ctx) const {
  const int pb = base.numParams();
  const int pc = cand.numParams();
  const int tilt = lin.extraColumns();  // nonlinear columns, copied from the base design
  const auto& bn = base.paramIndex().names();
  const auto& cn = cand.paramIndex().names();
  bool prefix = base_design.cols() == pb + tilt + 1 && pc >= pb;
  for (int k = 0; prefix && k < pb; ++k) prefix = bn[static_cast<std::size_t>(k)] == cn[static_cast<std::size_t>(k)];
  if (!prefix) return design(cand, lin);
  std::vector<const effects::Effect*> added;
  for (const auto& e : cand.effectList()) {
    if (!base.contains(e->name())) added.push_back(e.get());
  }
  const int n = data_.size();
  // The added effects' contributions alone, prewhitened, then the (already whitened) base columns.
  Design X = Design::Zero(6 * n, pc + tilt + 1);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, pc);
  const Vec6& w = data_.weights;
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = prepared_ctx[static_cast<std::size_t>(i)];
    Y.setZero();
    for (const auto* e : added) e->addRegressor(c, Y);
    for (int a = 0; a < 6; ++a) {
      double* row = X.data() + static_cast<std::ptrdiff_t>(rowOf(i, a)) * (pc + tilt + 1);
      for (int k = 0; k < pc; ++k) row[k] = w(a) * Y(a, k);
    }
  }
  whiten(X, 0, pc);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const double* src = base_design.data() + r * (pb + tilt + 1);
    double* row = X.data() + r * (pc + tilt + 1);
    for (int k = 0; k < pb; ++k) row[k] += src[k];
    for (int k = 0; k <= tilt; ++k) row[pc + k] = src[pb + k];
  }
  return X;
}

namespace {

/// Weighted SSE of theta on a block whose augmented Gram [X y]^T [X y] is G.
double sseFromGram(const Eigen::MatrixXd& G, const Eigen::VectorXd& theta) {
  const Eigen::Index p = theta.size();
  const double v = G(p, p) - 2.0 * theta.dot(G.col(p).head(p)) + theta.dot(G.topLeftCorner(p, p) * theta);
  return std::max(0.0, v);
}

}  // namespace

Solution Engine::solve(const Design& X, bool with_folds, const Design* raw) const {
  const bool with_series = raw != nullptr;
  const int p = static_cast<int>(X.cols()) - 1;
  const std::size_t nb = data_.blocks.size();
  // Augmented Gram of every (block, axis).
  std::vector<std::array<Eigen::MatrixXd, 6>> G(nb);
  std::vector<Eigen::MatrixXd> Gb(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    const Block& blk = data_.blocks[b];
    const int nbk = blk.end - blk.begin;
    Gb[b] = Eigen::MatrixXd::Zero(p + 1, p + 1);
    for (int a = 0; a < 6; ++a) {
      const auto rows = X.middleRows(6 * blk.begin + a * nbk, nbk);
      Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p + 1, p + 1);
      g.selfadjointView<Eigen::Lower>().rankUpdate(rows.transpose());
      G[b][static_cast<std::size_t>(a)] = g.selfadjointView<Eigen::Lower>();
      Gb[b] += G[b][static_cast<std::size_t>(a)];
    }
  }
  Solution sol;
  sol.p = p;
  Eigen::MatrixXd Gf = Eigen::MatrixXd::Zero(p + 1, p + 1);
  for (std::size_t b = 0; b < nb; ++b) {
    if (data_.blocks[b].fit) Gf += Gb[b];
  }
  const identify::GramSolution full = identify::solveGram(Gf.topLeftCorner(p, p), Gf.col(p).head(p), true);
  sol.theta = full.x;
  sol.rank = full.rank;
  sol.null_space = full.null_space;
  sol.condition_number = full.condition;
  int excluded_fit = 0;
  for (int i = 0; i < data_.n_fit; ++i) excluded_fit += excluded(i) ? 1 : 0;
  sol.rows_fit = 6 * (data_.n_fit - excluded_fit);
  sol.sse_fit = sseFromGram(Gf, sol.theta);
  // Per-axis sums in N^2 / Nm^2: whitened sums / w^2 / (1 - phi^2) (the marginal scale).
  Vec6 to_raw;
  for (int a = 0; a < 6; ++a) {
    to_raw(a) = 1.0 / (data_.weights(a) * data_.weights(a) * std::max(1e-6, 1.0 - data_.ar1(a) * data_.ar1(a)));
  }
  for (std::size_t b = 0; b < nb; ++b) {
    if (!data_.blocks[b].fit) continue;
    for (int a = 0; a < 6; ++a) sol.sse_fit_axis(a) += sseFromGram(G[b][static_cast<std::size_t>(a)], sol.theta) * to_raw(a);
  }
  sol.sigma2 = sol.sse_fit / std::max(1, sol.rows_fit - sol.rank);
  sol.covariance = sol.sigma2 * full.inverse;
  if (!with_folds) return sol;
  sol.n_heldout = 0;
  for (int i : test_samples_) sol.n_heldout += excluded(i) ? 0 : 1;
  if (with_series) sol.heldout_residual.resize(6, static_cast<Eigen::Index>(test_samples_.size()));
  int col = 0;
  for (int f = 0; f < data_.foldCount(); ++f) {
    Eigen::MatrixXd Gt = Eigen::MatrixXd::Zero(p + 1, p + 1);
    for (std::size_t b = 0; b < nb; ++b) {
      if (data_.trains(f, static_cast<int>(b))) Gt += Gb[b];
    }
    const identify::GramSolution fold = identify::solveGram(Gt.topLeftCorner(p, p), Gt.col(p).head(p), false);
    const int tb = data_.testBlock(f);
    const Block& blk = data_.blocks[static_cast<std::size_t>(tb)];
    const int nbk = blk.end - blk.begin;
    for (int a = 0; a < 6; ++a) {
      const double sse = sseFromGram(G[static_cast<std::size_t>(tb)][static_cast<std::size_t>(a)], fold.x);
      sol.sse_heldout += sse;
      sol.sse_heldout_axis(a) += sse * to_raw(a);
      if (with_series) {
        const auto rows = raw->middleRows(6 * blk.begin + a * nbk, nbk);
        const Eigen::VectorXd r = (rows.col(p) - rows.leftCols(p) * fold.x) / data_.weights(a);
        sol.heldout_residual.row(a).segment(col, nbk) = r.transpose();
      }
    }
    col += nbk;
  }
  if (with_series) {
    // Exact per-axis sums from the explicit residual in N / Nm, without the excluded samples.
    sol.sse_heldout_axis.setZero();
    for (std::size_t k = 0; k < test_samples_.size(); ++k) {
      if (!excluded(test_samples_[k])) sol.sse_heldout_axis += sol.heldout_residual.col(static_cast<Eigen::Index>(k)).cwiseAbs2();
    }
    if (data_.ar1.cwiseAbs().maxCoeff() == 0.0) {
      // White: the weighted total from the same sums (the Gram formula loses digits when the fit
      // is near perfect, e.g. noise-free data).
      sol.sse_heldout = sol.sse_heldout_axis.cwiseProduct(data_.weights.cwiseAbs2()).sum();
    }
  }
  return sol;
}

Mat6X Engine::predict(const Model& model, const Linearization& lin, const Eigen::VectorXd& theta,
                      bool exclude_derived) const {
  const int n = data_.size();
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

Mat6X Engine::timeDerivative(const Mat6X& w) const {
  return identify::timeDerivative(times_, w, data_.segment_start);
}

void Engine::tiltColumns(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  const int n = data_.size();
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

void Engine::mountColumns(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  const double h = 1e-5;
  for (int k = 0; k < 3; ++k) {
    Linearization lp = lin;
    Linearization lm = lin;
    lp.mount(k) += h;
    lm.mount(k) -= h;
    lin.j_m[k] = (predict(model, lp, theta, false) - predict(model, lm, theta, false)) / (2.0 * h);
  }
}

void Engine::delayColumn(const Model& model, Linearization& lin, const Eigen::VectorXd& theta) const {
  // d/dtau w(kinematics at t - tau) = -(dw/dt)(t - tau): minus the time derivative of the prediction.
  lin.j_d = -timeDerivative(predict(model, lin, theta, false));
}

Linearization Engine::initial(const Model& model) const {
  Linearization lin;
  if (model.estimatesTilt()) {
    // The fit's start (identify::initialTilt) on the fitting samples.
    std::vector<int> fit_samples(static_cast<std::size_t>(data_.n_fit));
    for (int i = 0; i < data_.n_fit; ++i) fit_samples[static_cast<std::size_t>(i)] = i;
    if (identify::initialTilt(data_.ctx, fit_samples, &lin.u, &lin.v)) {
      if (std::abs(lin.u) > 0.5 || std::abs(lin.v) > 0.5) lin.u = lin.v = 0.0;  // implausible: start level
    }
  }
  // Derived signals unknown yet: zero (their columns drop out of the first solve).
  return lin;
}

std::pair<Linearization, Solution> Engine::fitFully(const Model& model, const Linearization& start) const {
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
  Eigen::VectorXd theta;
  {
    const Solution s0 = solve(design(model, lin), false);
    theta = s0.theta.head(p);
  }
  if (delay && lin.delay == 0.0) {
    // Start for the delay: scan the shifted prediction of the model without delay (fit.hpp),
    // on the fitting data's first log.
    const int end = data_.segment_start.size() > 1 ? data_.segment_start[1] : data_.n_fit;
    const int n0 = std::min(end, data_.n_fit);
    std::vector<double> t(static_cast<std::size_t>(n0));
    Mat6X measured(6, n0);
    for (int i = 0; i < n0; ++i) {
      t[static_cast<std::size_t>(i)] = data_.ctx[static_cast<std::size_t>(i)].t;
      measured.col(i) = data_.ctx[static_cast<std::size_t>(i)].wrench_S;
    }
    const Mat6X pred = predict(model, lin, theta, false).leftCols(n0);
    lin.delay = identify::initialDelayEstimate(t, measured, pred, data_.weights, data_.max_delay_s);
    updateActive(lin);
    const Solution s1 = solve(design(model, lin), false);
    theta = s1.theta.head(p);
  }
  for (int it = 0; it < 30; ++it) {
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
    const Solution s = solve(design(model, lin), false);
    theta = s.theta.head(p);
    if (tilt) {
      const double du = s.theta(p);
      const double dv = s.theta(p + 1);
      lin.u += du;
      lin.v += dv;
      step = std::max(std::abs(du), std::abs(dv));
    }
    if (mount) {
      const Vec3 dm = s.theta.segment<3>(lin.mountColumn(p));
      lin.mount += dm;
      step = std::max(step, dm.cwiseAbs().maxCoeff());
    }
    if (delay) {
      const double dd = std::clamp(s.theta(lin.delayColumn(p)), -data_.max_delay_s - lin.delay, data_.max_delay_s - lin.delay);
      lin.delay += dd;
      step = std::max(step, std::abs(dd));
      updateActive(lin);
    }
    if (step < 1e-9 && change < 1e-6) break;
  }
  // Final linearisation at the converged point; the derived signals of this model for candidates.
  if (tilt) tiltColumns(model, lin, theta);
  if (mount) mountColumns(model, lin, theta);
  if (delay) delayColumn(model, lin, theta);
  lin.tilt_columns = tilt;
  lin.mount_columns = mount;
  lin.delay_column = delay;
  const Design raw = rawDesign(model, lin);
  Solution sol = solve(design(model, lin), true, &raw);
  if (!derived) {
    lin.w_model = predict(model, lin, sol.theta, true);
    lin.dw_dt = timeDerivative(lin.w_model);
  }
  return {lin, sol};
}

}  // namespace ftid::lab::detail
