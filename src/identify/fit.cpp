// General weighted least-squares fit of a composed model with variable projection on the tilt
// (include/ftid/identify/fit.hpp, docs/identification.md).
#include "ftid/identify/fit.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

#include "concurrency.hpp"
#include "linear_algebra.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/identify/uncertainty.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify {

namespace {

using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using effects::kSignalModelWrench;
using effects::NonlinearParams;

constexpr double kAngleStep = 1e-6;       // [rad] numeric-Jacobian step for tilt and mounting
constexpr double kDelayStep = 1e-6;       // [s] numeric-Jacobian step for the delay
constexpr double kStepConverged = 1e-10;  // a rejected Gauss-Newton step this small ends the search
/// The compressed tilt search factors its per-axis data through the Gram matrix (rounding error
/// ~ cond^2 eps, about 1e-10 relative at this bound) only while the column-scaled regressor at the
/// start is at most this ill-conditioned; beyond it, Householder QR (rounding ~ cond eps).
constexpr double kGramConditionLimit = 1e3;
/// From this many samples the compressed tilt search's passes over the data run in two halves,
/// the second on a thread of its own (internal::runConcurrently).
constexpr int kParallelSamples = internal::kParallelRows;

/// Which nonlinear parameters a model estimates, and where they sit in the vector phi.
struct PhiLayout {
  int tilt = -1;   ///< index of U (V follows), or -1
  int mount = -1;  ///< index of roll (pitch, yaw follow), or -1
  int delay = -1;  ///< index of the delay, or -1
  int size = 0;

  explicit PhiLayout(const Model& m) {
    if (m.estimatesTilt()) { tilt = size; size += 2; }
    if (m.estimatesMounting()) { mount = size; size += 3; }
    if (m.estimatesDelay()) { delay = size; size += 1; }
  }
  double step(int k) const { return k == delay ? kDelayStep : kAngleStep; }
  NonlinearParams params(const Eigen::VectorXd& phi, const NonlinearParams& fixed) const {
    NonlinearParams p = fixed;
    if (tilt >= 0) { p.tilt_u_rad = phi(tilt); p.tilt_v_rad = phi(tilt + 1); }
    if (mount >= 0) p.mount_rpy_rad = phi.segment<3>(mount);
    if (delay >= 0) p.delay_s = phi(delay);
    return p;
  }
  Eigen::VectorXd vector(const NonlinearParams& p) const {
    Eigen::VectorXd phi(size);
    if (tilt >= 0) { phi(tilt) = p.tilt_u_rad; phi(tilt + 1) = p.tilt_v_rad; }
    if (mount >= 0) phi.segment<3>(mount) = p.mount_rpy_rad;
    if (delay >= 0) phi(delay) = p.delay_s;
    return phi;
  }
};

struct Problem {
  const Model& model;
  const std::vector<SampleContext>& contexts;
  const std::vector<int>& indices;
  int n = 0;
  int p = 0;
  bool override_gravity = false;  ///< recompute g_S from the tilt (else use ctx.g_S)
  bool mounting = false;
  bool delay = false;
  bool reads_wmodel = false;      ///< the model reads kSignalModelWrench
  std::vector<Wrench> wmodel;     ///< SampleContext::wrench_model_S per subset sample
  /// Gauss-Newton linearisation of the effects that read the modelled wrench (crosstalk): with
  /// gn_theta set (the current solution), the model (I + E) w_base(theta) is linearised at it,
  ///   f ~ (I + E0) Y_base theta + X(w_base0) e - E0 w_base0,
  /// so the base columns get E0 applied and the measurement gets + E0 w_base0 (buildRegressor's
  /// rhs); a plain fixed point (wrench_model_S frozen) converges far too slowly with noise.
  Eigen::VectorXd gn_theta;
  double gn_lambda = 0.0;         ///< Levenberg damping of theta towards gn_theta (scaled columns)
  std::vector<char> derived_col;  ///< columns owned by effects that read the modelled wrench
  std::vector<const effects::Effect*> derived_effects;  ///< those effects
  std::vector<char> active;       ///< samples whose delayed kinematics lie inside the data
  int n_active = 0;
  Eigen::VectorXd y;              ///< stacked measured wrench (6n)

  Problem(const Model& m, const std::vector<SampleContext>& c, const std::vector<int>& idx)
      : model(m), contexts(c), indices(idx), n(static_cast<int>(idx.size())), p(m.numParams()),
        mounting(m.estimatesMounting()), delay(m.estimatesDelay()),
        reads_wmodel((m.signals() & kSignalModelWrench) != 0),
        derived_col(static_cast<std::size_t>(m.numParams()), 0),
        derived_effects(effects::modelWrenchEffects(m)),
        active(static_cast<std::size_t>(idx.size()), 1), n_active(static_cast<int>(idx.size())) {
    for (const auto& e : m.effectList()) {
      if ((e->signals() & kSignalModelWrench) == 0) continue;
      for (const auto& info : e->params()) {
        const int col = m.paramIndex().column(info.name);
        if (col >= 0) derived_col[static_cast<std::size_t>(col)] = 1;
      }
    }
  }

  const SampleContext& at(int i) const { return contexts[static_cast<std::size_t>(indices[static_cast<std::size_t>(i)])]; }

  /// Sample i prepared for the nonlinear parameters (effects/nonlinear.hpp): the reading with the
  /// kinematics at t_i - delay (nearest end outside the data), the mounting rotation, gravity.
  void prepare(int i, const NonlinearParams& nl, const Vec3& g_B, const Mat3& R_SM, SampleContext* c) const {
    *c = at(i);
    if (delay && nl.delay_s != 0.0) {
      const double ts = std::clamp(c->t - nl.delay_s, at(0).t, at(n - 1).t);
      effects::kinematicsAt([this](int k) -> const SampleContext& { return at(k); }, n, ts, c);
    }
    if (mounting) effects::applyMounting(R_SM, c);
    if (override_gravity) c->g_S = c->R_BS.transpose() * g_B;
  }

  /// Marks the samples whose delayed kinematics stay inside the data for every delay in [lo, hi].
  void setActiveWindow(double lo, double hi) {
    n_active = 0;
    for (int i = 0; i < n; ++i) {
      const double t = at(i).t;
      const bool ok = !delay || (t - hi >= at(0).t - 1e-9 && t - lo <= at(n - 1).t + 1e-9);
      active[static_cast<std::size_t>(i)] = ok ? 1 : 0;
      n_active += ok ? 1 : 0;
    }
  }

  /// Regressor A (6n x p) for the nonlinear parameters, rows scaled by the axis weights and
  /// zero for inactive samples. wrench_model_S is that of wmodel, or zero if !with_derived (the
  /// regressor of the effects that do not read it: those effects are linear in it). With gn_theta
  /// set, the Gauss-Newton form (see gn_theta) and its measurement shift, weighted, in *rhs.
  void buildRegressor(const NonlinearParams& nl, const Vec6& weights, Eigen::MatrixXd* A,
                      bool with_derived = true, Eigen::VectorXd* rhs = nullptr) const {
    A->resize(6 * n, p);
    const bool gn = with_derived && reads_wmodel && gn_theta.size() == p;
    if (rhs != nullptr) rhs->setZero(6 * n);
    const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
    const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y2(6, p);
    SampleContext c;
    for (int i = 0; i < n; ++i) {
      if (!active[static_cast<std::size_t>(i)]) {
        A->middleRows(6 * i, 6).setZero();
        continue;
      }
      prepare(i, nl, g_B, R_SM, &c);
      c.wrench_model_S = (reads_wmodel && with_derived) ? wmodel[static_cast<std::size_t>(i)] : Wrench::Zero();
      model.computeRegressor(c, Y);
      if (gn) {
        // E0 as a 6 x 6 matrix for this sample: the derived effects are linear in wrench_model_S,
        // so column k is their contribution with wrench_model_S = e_k (only those effects run).
        const Mat6 E0 = effects::modelWrenchMap(derived_effects, c, gn_theta, Y2);
        const Wrench shift = E0 * wmodel[static_cast<std::size_t>(i)];
        for (int j = 0; j < p; ++j) {
          if (!derived_col[static_cast<std::size_t>(j)]) Y.col(j) += E0 * Y.col(j);
        }
        if (rhs != nullptr) rhs->segment<6>(6 * i) = weights.cwiseProduct(shift);
      }
      A->middleRows(6 * i, 6) = weights.asDiagonal() * Y;
    }
  }

  Eigen::VectorXd weightedMeasurement(const Vec6& weights) const {
    Eigen::VectorXd yw(6 * n);
    for (int i = 0; i < n; ++i) {
      yw.segment<6>(6 * i) = active[static_cast<std::size_t>(i)] ? Vec6(weights.cwiseProduct(y.segment<6>(6 * i)))
                                                                 : Vec6::Zero();
    }
    return yw;
  }

  /// Modelled wrench (6 x n, unweighted) of theta with effects::ModelEvaluator (the compensator's
  /// code); with reads_wmodel and !self_consistent, wrench_model_S comes from wmodel instead.
  Mat6X predict(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
    const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
    const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
    effects::ModelEvaluator eval(model, theta);
    Mat6X out(6, n);
    SampleContext c;
    for (int i = 0; i < n; ++i) {
      prepare(i, nl, g_B, R_SM, &c);
      out.col(i) = eval.evaluate(c);
    }
    return out;
  }

  /// The prediction of the effects that do not read the modelled wrench (what crosstalk multiplies).
  std::vector<Wrench> basePrediction(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
    const Mat6X w = predictWithoutDerived(theta, nl);
    std::vector<Wrench> out(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = w.col(i);
    return out;
  }

  Mat6X predictWithoutDerived(const Eigen::VectorXd& theta, const NonlinearParams& nl) const {
    const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
    const Mat3 R_SM = effects::mountingRotation(nl.mount_rpy_rad);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
    Mat6X out(6, n);
    SampleContext c;
    for (int i = 0; i < n; ++i) {
      prepare(i, nl, g_B, R_SM, &c);
      c.wrench_model_S.setZero();
      model.computeRegressor(c, Y);
      out.col(i) = Y * theta;
    }
    return out;
  }
};

struct LinearSolution {
  Eigen::VectorXd theta;
  Eigen::VectorXd residual;  ///< weighted, stacked
};

LinearSolution solveLinear(const Eigen::MatrixXd& A, const Eigen::VectorXd& yw) {
  LinearSolution s;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  s.theta = qr.solve(yw);
  s.residual = yw - A * s.theta;
  return s;
}

/// 0 if every field the fit reads is finite, NaN otherwise (x * 0 is 0 for every finite x and NaN
/// for +-inf and NaN): the one list of the fields, for the fast pass and for naming the sample.
double nonFiniteProbe(const SampleContext& c) {
  return (c.wrench_S.array() * 0.0).sum() + (c.R_BS.array() * 0.0).sum() + (c.w_S.array() * 0.0).sum() +
         (c.alpha_S.array() * 0.0).sum() + (c.a_S.array() * 0.0).sum() + (c.g_S.array() * 0.0).sum() +
         c.t * 0.0 + c.t_model * 0.0 + (c.imu_acc_S.array() * 0.0).sum() + (c.imu_w_S.array() * 0.0).sum() +
         (c.imu_alpha_S.array() * 0.0).sum() + c.temp_degC * 0.0;
}

void checkFinite(const Problem& pb) {
  double zero = 0.0;
  for (int i = 0; i < pb.n; ++i) zero += nonFiniteProbe(pb.at(i));
  if (zero == 0.0) return;
  // Name the first sample with a non-finite value.
  for (int i = 0; i < pb.n; ++i) {
    const SampleContext& c = pb.at(i);
    if (nonFiniteProbe(c) != 0.0) {
      throw DataError("sample " + std::to_string(pb.indices[static_cast<std::size_t>(i)]) +
                      " (t = " + std::to_string(c.t) + " s) has a non-finite value");
    }
  }
}

/// Scratch memory of the compressed tilt search (the rows of B_a and the scores, ~80 doubles per
/// sample), kept per thread between calls. Fresh pages cost a page fault each (1-1.5 us on the
/// development VM): at 1,251 samples the ~290 faults of a fit's transient matrices were a third of
/// its time, paid again on every call once glibc returns the memory. A repeated fit
/// (cross-validation, a cell that re-identifies, a benchmark) reuses the pages; capacity beyond
/// kKeptDoubles (64 MB) is released when the call ends. A nested lease on the same thread (none
/// today) gets memory of its own.
class ThreadScratch {
 public:
  ThreadScratch() : arena_(threadArena()) {
    if (arena_.in_use) {
      own_ = true;
    } else {
      arena_.in_use = true;
    }
  }
  ~ThreadScratch() {
    if (own_) return;
    arena_.in_use = false;
    if (arena_.capacity > kKeptDoubles) {
      arena_.data.reset();
      arena_.capacity = 0;
    }
  }
  ThreadScratch(const ThreadScratch&) = delete;
  ThreadScratch& operator=(const ThreadScratch&) = delete;

  /// At least `count` doubles, uninitialised contents (earlier contents are lost when it grows).
  double* reserve(std::size_t count) {
    Arena& a = own_ ? local_ : arena_;
    if (a.capacity < count) {
      a.data.reset();  // the old block first: peak memory is one block
      a.data = std::unique_ptr<double[]>(new double[count]);  // not zeroed: every entry is written before it is read
      a.capacity = count;
    }
    return a.data.get();
  }

 private:
  static constexpr std::size_t kKeptDoubles = std::size_t{8} << 20;  // 64 MB
  struct Arena {
    std::unique_ptr<double[]> data;
    std::size_t capacity = 0;
    bool in_use = false;
  };
  static Arena& threadArena() {
    static thread_local Arena arena;
    return arena;
  }
  Arena& arena_;
  Arena local_;
  bool own_ = false;
};

/// The compressed tilt search (FitOptions::compressed_tilt_search; docs/identification.md).
///
/// For a model whose only nonlinear parameters are the tilt (no mounting, delay or effects that
/// read the modelled wrench), the tilt enters only through g_S = R_BS^T g_B and the regressor is
/// affine in g_S (checked on a sample of the data; e.g. harmonic(gx,1) is not, and then the general
/// path runs). So per axis a, with s = standard gravity and e_k the base axes,
///
///   A_a(g_B) = A0_a + sum_k (g_B(k) / s) E_k,a      A0_a = A_a(g_S = 0), E_k,a = A_a(s R_BS^T e_k) - A0_a
///
/// is a fixed combination M_a(g_B) of the columns of B_a = [A0_a E_0,a E_1,a E_2,a y_a] (N x c_a,
/// columns that are zero in every sample left out). Any c_a x c_a factor R_a with
/// R_a^T R_a = B_a^T B_a (the Gram matrix) gives, for the per-axis weights w_a,
///
///   sum_i |W (w_i - Y_i(g_B) theta)|^2 = sum_a w_a^2 |R_a (e_y - M_a(g_B) theta)|^2
///
/// exactly, so every solve of the variable projection is a QR of the stacked [w_a R_a M_a(g_B)]
/// (sum_a c_a rows, p columns), independent of N, with the same Gauss-Newton steps. The same holds
/// for the joint Jacobian [A(g_B), dA/dU theta, dA/dV theta] (its rank, condition number and
/// (J^T J)^{-1}); only the Newey-West scores and the per-sample residual need the rows, one pass
/// over B_a. R_a comes from the Gram matrix accumulated in one pass (pivoted LDLT of the
/// column-scaled Gram of the regressor columns, the measurement column last) when the problem is
/// well conditioned (rounding error ~ cond^2 eps, kGramConditionLimit: checked on the regressor at
/// the start and on the final joint Jacobian), else from the thin Householder QR B_a = Q_a R_a
/// (internal::thinR, rounding ~ cond eps).
class GravityCompression {
 public:
  /// Evaluates B_a for every sample; false if the regressor is not affine in g_S (checked at
  /// g_check_B on the probe samples). Its pass over the data also runs checkFinite's test (throws
  /// DataError naming the first non-finite sample); after false, the caller runs checkFinite.
  bool build(const Problem& pb, const Vec3& g_check_B) {
    const int n = pb.n;
    const int p = pb.p;
    p_ = p;
    const int m = 4 * p + 1;  // [A0 E0 E1 E2 y]
    // The probe samples: the affine check and the first guess of the non-zero columns.
    const int stride = std::max(1, n / 64);
    // Effects whose contribution changes with g_S on a probe sample are evaluated four times per
    // sample (g_S = 0 and the three base axes), the others once. An effect with a constant gravity
    // slope (Effect::constantGravitySlope, e.g. gravity) is evaluated once, at g_S = 0, and its
    // slopes D_j (taken once) give E_k = sum_j s R_BS(k, j) D_j. A misclassified effect would show
    // in the affine check of the full regressor below.
    const auto& effect_list = pb.model.effectList();
    std::vector<const effects::Effect*> fixed_effects, gravity_effects;
    // Non-zero entries e (of 6 x p, column-major) of sum_j g_S(j) D_j over the constant-slope
    // effects, with their (D_0, D_1, D_2).
    std::vector<int> slope_entry;
    std::vector<Vec3> slope_value;
    {
      Eigen::Matrix<double, 6, Eigen::Dynamic> Z0(6, p), Zk(6, p);
      Eigen::Matrix<double, 6, Eigen::Dynamic> D[3];
      for (auto& Dj : D) Dj.setZero(6, p);
      SampleContext c;
      for (const auto& e : effect_list) {
        bool reads_g = false;
        for (int i = 0; i < n && !reads_g; i += stride) {
          c = pb.at(i);
          c.wrench_model_S.setZero();
          c.g_S.setZero();
          Z0.setZero();
          e->addRegressor(c, Z0);
          for (int k = 0; k < 3 && !reads_g; ++k) {
            c.g_S = kStandardGravity * c.R_BS.row(k).transpose();
            Zk.setZero();
            e->addRegressor(c, Zk);
            reads_g = Zk != Z0;
          }
        }
        if (reads_g && e->constantGravitySlope()) {
          c = pb.at(0);
          c.wrench_model_S.setZero();
          c.g_S.setZero();
          Z0.setZero();
          e->addRegressor(c, Z0);
          for (int j = 0; j < 3; ++j) {
            c.g_S = Vec3::Unit(j);
            Zk.setZero();
            e->addRegressor(c, Zk);
            D[j] += Zk - Z0;
          }
          fixed_effects.push_back(e.get());  // its g_S = 0 part
        } else {
          (reads_g ? gravity_effects : fixed_effects).push_back(e.get());
        }
      }
      for (int e = 0; e < 6 * p; ++e) {
        const Vec3 d(D[0].data()[e], D[1].data()[e], D[2].data()[e]);
        if (d.isZero(0.0)) continue;
        slope_entry.push_back(e);
        slope_value.push_back(d);
      }
    }
    // Y4 = [Y0 E0 E1 E2] (6 x 4p) of one sample. Without effects evaluated at every gravity
    // direction, the entries of E_k outside slope_entry stay zero (set once here).
    // One per thread of the pass (the effects are const and keep no state).
    struct Work {
      SampleContext c;
      Eigen::Matrix<double, 6, Eigen::Dynamic> Y4;
      Eigen::Matrix<double, 6, Eigen::Dynamic> Yc;
      explicit Work(int p_cols) : Y4(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, 4 * p_cols)), Yc(6, p_cols) {}
    };
    const bool general_gravity = !gravity_effects.empty();
    const std::size_t n_slope = slope_entry.size();
    auto evaluate = [&](int i, Work& wk) {
      SampleContext& c = wk.c;
      auto& Y4 = wk.Y4;
      auto& Yc = wk.Yc;
      c = pb.at(i);
      c.wrench_model_S.setZero();
      c.g_S.setZero();
      auto Y0 = Y4.leftCols(p);
      Y0.setZero();
      for (const auto* e : fixed_effects) e->addRegressor(c, Y0);
      if (general_gravity) {
        Yc.setZero();
        for (const auto* e : gravity_effects) e->addRegressor(c, Yc);
        Y0 += Yc;
      }
      for (int k = 0; k < 3; ++k) {
        auto Ek = Y4.middleCols((k + 1) * p, p);
        const Vec3 g_S = kStandardGravity * c.R_BS.row(k).transpose();  // R_BS^T (s e_k)
        double* ek = Ek.data();
        if (general_gravity) {
          c.g_S = g_S;
          Ek = -Yc;
          for (const auto* e : gravity_effects) e->addRegressor(c, Ek);
          for (std::size_t q = 0; q < n_slope; ++q) ek[slope_entry[q]] += g_S.dot(slope_value[q]);
        } else {
          for (std::size_t q = 0; q < n_slope; ++q) ek[slope_entry[q]] = g_S.dot(slope_value[q]);
        }
      }
    };
    Work main_work(p);
    SampleContext& c = main_work.c;
    auto& Y4 = main_work.Y4;
    auto& Yc = main_work.Yc;
    // Affine in g_S: the full regressor at g_check_B equals the combination (after evaluate(i)).
    auto affine = [&]() {
      c.g_S = c.R_BS.transpose() * g_check_B;
      pb.model.computeRegressor(c, Yc);
      Eigen::Matrix<double, 6, Eigen::Dynamic> comb = Y4.leftCols(p);
      for (int k = 0; k < 3; ++k) comb += (g_check_B(k) / kStandardGravity) * Y4.middleCols((k + 1) * p, p);
      const double scale = std::max(1.0, Yc.cwiseAbs().maxCoeff());
      return (Yc - comb).cwiseAbs().maxCoeff() <= 1e-9 * scale;
    };
    // Non-zero entries of Y4 (column-major index 6 col + a), first from the probe samples; a full
    // pass that meets another one adds it and runs again (the union after a full pass is exact).
    const int entries = 6 * 4 * p;
    std::vector<char> used(static_cast<std::size_t>(entries), 0);
    for (int i = 0; i < n; i += stride) {
      evaluate(i, main_work);
      if (!affine()) return false;
      for (int e = 0; e < entries; ++e) used[static_cast<std::size_t>(e)] |= Y4.data()[e] != 0.0 ? 1 : 0;
    }
    // The data of the paper's static force stage (initialTilt): f0_a's column is 1 and the mass
    // column's E_k is s R_BS(k, a) in every sample (the gravity and offsets effects alone).
    const auto& index = pb.model.paramIndex();
    const int c_mass = index.column("mass");
    const int c_f0[3] = {index.column("f0_x"), index.column("f0_y"), index.column("f0_z")};
    bool force_stage = c_mass >= 0 && c_f0[0] >= 0 && c_f0[1] >= 0 && c_f0[2] >= 0;
    Eigen::Array<double, 6, Eigen::Dynamic> left_out(6, 4 * p);  // 1 for an entry left out of B_a
    std::vector<char> found(static_cast<std::size_t>(entries), 0);  // left out but non-zero somewhere
    constexpr int kGramBlock = 256;
    for (int pass = 0; pass < 2; ++pass) {
      // Column maps: B_a's columns are the used entries of axis a in the order (k, j), then y.
      for (int a = 0; a < 6; ++a) {
        std::vector<int>& map = col_[static_cast<std::size_t>(a)];
        std::vector<int>& src = src_[static_cast<std::size_t>(a)];
        map.assign(static_cast<std::size_t>(m), -1);
        src.clear();
        for (int col = 0; col < 4 * p; ++col) {
          if (used[static_cast<std::size_t>(6 * col + a)]) {
            map[static_cast<std::size_t>(col)] = static_cast<int>(src.size());
            src.push_back(6 * col + a);
          }
        }
        map[static_cast<std::size_t>(m - 1)] = static_cast<int>(src.size());
        b_cols_[static_cast<std::size_t>(a)] = static_cast<Eigen::Index>(src.size()) + 1;
      }
      // One block of scratch: B_0 .. B_5 (row-major, N x c_a each), then the scores (N x (p + 2)).
      n_ = n;
      std::size_t total = 0;
      for (int a = 0; a < 6; ++a) {
        b_offset_[static_cast<std::size_t>(a)] = total;
        total += static_cast<std::size_t>(n) * static_cast<std::size_t>(b_cols_[static_cast<std::size_t>(a)]);
      }
      s_offset_ = total;
      total += static_cast<std::size_t>(n) * static_cast<std::size_t>(p + 2);
      data_ = scratch_.reserve(total);
      for (int e = 0; e < entries; ++e) left_out.data()[e] = used[static_cast<std::size_t>(e)] ? 0.0 : 1.0;
      std::vector<int> left_out_slope;  // entries of E_k from the slopes that are left out
      for (int k = 0; k < 3; ++k) {
        for (const int e : slope_entry) {
          if (!used[static_cast<std::size_t>(6 * (k + 1) * p + e)]) left_out_slope.push_back(6 * (k + 1) * p + e);
        }
      }
      // What a range of samples contributes (the pass runs in two ranges, see below).
      struct Part {
        std::array<Eigen::MatrixXd, 6> G;  ///< lower triangles
        std::vector<char> found;
        double non_finite = 0.0;           ///< the finite check of the data (checkFinite) in the same pass
        bool force_stage = true;
      };
      auto runRange = [&](int begin, int end, Work& wk, Part& part) {
        for (int a = 0; a < 6; ++a) {
          const Eigen::Index ca = b_cols_[static_cast<std::size_t>(a)];
          part.G[static_cast<std::size_t>(a)].setZero(ca, ca);
        }
        part.found.assign(static_cast<std::size_t>(entries), 0);
        part.force_stage = force_stage;
        const auto& Y4w = wk.Y4;
        for (int i = begin; i < end; ++i) {
          evaluate(i, wk);
          if (pass == 0) part.non_finite += nonFiniteProbe(pb.at(i));  // its cache lines were just read
          const double* y4 = Y4w.data();
          const Wrench& w = pb.at(i).wrench_S;
          for (int a = 0; a < 6; ++a) {
            const std::vector<int>& src = src_[static_cast<std::size_t>(a)];
            double* row = rowOf(a, i);  // one sample's row, contiguous
            const std::size_t ns = src.size();
            for (std::size_t j = 0; j < ns; ++j) row[j] = y4[src[j]];
            row[ns] = w(a);
          }
          // An entry left out must stay zero in every sample (a sum of |entries|: zero iff all are).
          // Without effects evaluated at every gravity direction, E_k is zero outside the slope
          // entries: Y0 and the slope entries left out suffice.
          bool any_left = false;
          if (general_gravity) {
            any_left = (Y4w.array().abs() * left_out).sum() != 0.0;
          } else {
            any_left = (Y4w.leftCols(p).array().abs() * left_out.leftCols(p)).sum() != 0.0;
            for (const int e : left_out_slope) any_left = any_left || y4[e] != 0.0;
          }
          if (any_left) {
            for (int e = 0; e < entries; ++e) {
              part.found[static_cast<std::size_t>(e)] |= left_out.data()[e] != 0.0 && y4[e] != 0.0 ? 1 : 0;
            }
          }
          if (part.force_stage) {
            for (int a = 0; a < 3; ++a) {
              part.force_stage = part.force_stage && Y4w(a, c_f0[a]) == 1.0;
              for (int k = 0; k < 3; ++k) {
                part.force_stage =
                    part.force_stage && Y4w(a, (k + 1) * p + c_mass) == kStandardGravity * wk.c.R_BS(k, a);
              }
            }
          }
          // The Gram matrices, a block of rows at a time while it is in the cache.
          if ((i + 1 - begin) % kGramBlock == 0 || i == end - 1) {
            const int i0 = i - (i - begin) % kGramBlock;
            for (int a = 0; a < 6; ++a) {
              part.G[static_cast<std::size_t>(a)].selfadjointView<Eigen::Lower>().rankUpdate(
                  rowsOf(a).middleRows(i0, i - i0 + 1).transpose());
            }
          }
        }
      };
      // Two ranges from kParallelSamples on (a split that depends on n alone, so the sums and the
      // result do not depend on the machine), the second on a thread of its own where there is a
      // second core; their Gram matrices added in range order.
      std::array<Part, 2> parts;
      const int mid = n >= kParallelSamples ? n / 2 : n;
      if (mid < n) {
        Work second_work(p);
        if (!internal::runConcurrently([&] { runRange(mid, n, second_work, parts[1]); },
                             [&] { runRange(0, mid, main_work, parts[0]); })) {
          runRange(0, mid, main_work, parts[0]);
          runRange(mid, n, second_work, parts[1]);
        }
      } else {
        runRange(0, n, main_work, parts[0]);
      }
      double non_finite = 0.0;
      for (int q = 0; q < (mid < n ? 2 : 1); ++q) {
        const Part& part = parts[static_cast<std::size_t>(q)];
        for (int a = 0; a < 6; ++a) {
          if (q == 0) {
            G_[static_cast<std::size_t>(a)] = part.G[static_cast<std::size_t>(a)];
          } else {
            G_[static_cast<std::size_t>(a)] += part.G[static_cast<std::size_t>(a)];
          }
        }
        for (int e = 0; e < entries; ++e) found[static_cast<std::size_t>(e)] |= part.found[static_cast<std::size_t>(e)];
        non_finite += part.non_finite;
        force_stage = force_stage && part.force_stage;
      }
      if (non_finite != 0.0) checkFinite(pb);  // throws, naming the first such sample
      bool complete = true;
      for (int e = 0; e < entries; ++e) {
        if (!used[static_cast<std::size_t>(e)] && found[static_cast<std::size_t>(e)]) {
          used[static_cast<std::size_t>(e)] = 1;
          complete = false;
        }
      }
      if (complete) break;
      if (pass == 1) return false;  // cannot happen: the first full pass found every column
    }
    force_stage_ = force_stage;
    c_mass_ = c_mass;
    for (int a = 0; a < 3; ++a) c_f0_[a] = c_f0[a];
    return true;
  }

  /// Factors every B_a (R_a^T R_a = B_a^T B_a): from the Gram matrix (gram) or by Householder QR.
  void factor(bool gram) {
    gram_ = gram;
    rows_ = 0;
    for (int a = 0; a < 6; ++a) {
      const auto Ba = rowsOf(a);
      Eigen::MatrixXd& Ra = R_[static_cast<std::size_t>(a)];
      if (gram) {
        const Eigen::Index ca = Ba.cols();
        Eigen::MatrixXd G = G_[static_cast<std::size_t>(a)];  // lower triangle, accumulated in build()
        G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
        Eigen::VectorXd d(ca);  // column scaling
        for (Eigen::Index j = 0; j < ca; ++j) d(j) = G(j, j) > 0.0 ? std::sqrt(G(j, j)) : 1.0;
        const Eigen::MatrixXd Gs = d.cwiseInverse().asDiagonal() * G * d.cwiseInverse().asDiagonal();
        // The regressor columns (y, the last, apart): pivoted LDLT, semidefinite allowed,
        // Gs_AA = P^T L D L^T P, so R_AA = sqrt(D) L^T P (Eigen's transpositionsP() from the right
        // is P^T). Then R_AA^T r_Ay = Gs_Ay and rho^2 = Gs_yy - |r_Ay|^2: the part of y outside
        // every column is the last pivot, a constant of the cost whatever its rounding, and the
        // tilt search's cost and steps depend only on the well-conditioned rest.
        const Eigen::Index cr = ca - 1;
        if (cr == 0) {  // no regressor column on this axis
          Ra = Eigen::MatrixXd::Constant(1, 1, std::sqrt(G(0, 0)));
          offset_[static_cast<std::size_t>(a)] = rows_;
          rows_ += 1;
          continue;
        }
        const Eigen::LDLT<Eigen::MatrixXd> ldlt(Gs.topLeftCorner(cr, cr));
        const Eigen::VectorXd sd = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
        Ra = Eigen::MatrixXd::Zero(ca, ca);
        Ra.topLeftCorner(cr, cr) = sd.asDiagonal() * Eigen::MatrixXd(ldlt.matrixU());
        Ra.topLeftCorner(cr, cr) = Ra.topLeftCorner(cr, cr) * ldlt.transpositionsP().transpose();
        Eigen::VectorXd x = ldlt.transpositionsP() * Gs.col(cr).head(cr);
        ldlt.matrixL().solveInPlace(x);
        for (Eigen::Index j = 0; j < cr; ++j) x(j) = sd(j) > 0.0 ? x(j) / sd(j) : 0.0;
        Ra.col(cr).head(cr) = x;
        Ra(cr, cr) = std::sqrt(std::max(0.0, Gs(cr, cr) - x.squaredNorm()));
        Ra = Ra * d.asDiagonal();
      } else {
        Eigen::MatrixXd D = Ba;  // thinR factors in place; B_a stays for the per-sample rows
        Ra = internal::thinR(D);
      }
      offset_[static_cast<std::size_t>(a)] = rows_;
      rows_ += Ra.rows();
    }
    // Stacked column blocks P_k (rows x p): P_k's column j is R_a's column of (k, j) (zero if absent).
    for (auto& P : P_) P = Eigen::MatrixXd::Zero(rows_, p_);
    Py_ = Eigen::VectorXd::Zero(rows_);
    axis_of_row_.resize(rows_);
    for (int a = 0; a < 6; ++a) {
      const auto& Ra = R_[static_cast<std::size_t>(a)];
      const Eigen::Index o = offset_[static_cast<std::size_t>(a)];
      const Eigen::Index ra = Ra.rows();
      axis_of_row_.segment(o, ra).setConstant(a);
      for (int k = 0; k < 4; ++k) {
        for (int j = 0; j < p_; ++j) {
          const int bc = col_[static_cast<std::size_t>(a)][static_cast<std::size_t>(k * p_ + j)];
          if (bc >= 0) P_[static_cast<std::size_t>(k)].block(o, j, ra, 1) = Ra.col(bc);
        }
      }
      Py_.segment(o, ra) = Ra.col(col_[static_cast<std::size_t>(a)][static_cast<std::size_t>(4 * p_)]);
    }
  }
  bool gram() const { return gram_; }

  /// The fit's start (U, V): the paper's static force stage f_i = R_BS,i^T L + F0 (the same as
  /// initialTilt(), paper_method.cpp) solved on the compressed force axes, whose columns hold its
  /// data exactly. False (u, v untouched) if the model lacks those columns, the force stage is not
  /// determined, or (Gram factor) too ill-conditioned for it: then initialTilt() decides.
  bool initialTilt(double rank_tolerance, double* tilt_u_rad, double* tilt_v_rad) const {
    if (!force_stage_) return false;
    Eigen::Index rows = 0;
    for (int a = 0; a < 3; ++a) rows += R_[static_cast<std::size_t>(a)].rows();
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(rows, 6);  // unknowns [L, F0]
    Eigen::VectorXd z(rows);
    for (int a = 0, o = 0; a < 3; ++a) {
      const auto& map = col_[static_cast<std::size_t>(a)];
      const auto& Ra = R_[static_cast<std::size_t>(a)];
      const Eigen::Index ra = Ra.rows();
      for (int k = 0; k < 3; ++k) {
        const int bc = map[static_cast<std::size_t>((k + 1) * p_ + c_mass_)];
        if (bc < 0) return false;  // R_BS(k, a) = 0 in every sample: not determined
        K.block(o, k, ra, 1) = Ra.col(bc) / kStandardGravity;
      }
      const int bf = map[static_cast<std::size_t>(c_f0_[a])];
      if (bf < 0) return false;
      K.block(o, 3 + a, ra, 1) = Ra.col(bf);
      z.segment(o, ra) = Ra.col(map[static_cast<std::size_t>(4 * p_)]);
      o += static_cast<int>(ra);
    }
    const internal::ScaledQR qr(K, rank_tolerance);
    if (qr.rank().rank < 6 || (gram_ && qr.rank().condition_number > kGramConditionLimit)) return false;
    const Eigen::VectorXd l = qr.solve(z);
    double weight_N = 0.0;
    gravityToWeightAndTilt(l.head<3>(), &weight_N, tilt_u_rad, tilt_v_rad);
    return true;
  }

  /// Weighted compressed regressor [w_a R_a M_a(g_B)] (rows() x p) and measurement.
  void compressed(const Vec3& g_B, const Vec6& w, Eigen::MatrixXd* C, Eigen::VectorXd* z) const {
    *C = P_[0];
    for (int k = 0; k < 3; ++k) *C += (g_B(k) / kStandardGravity) * P_[static_cast<std::size_t>(k + 1)];
    *z = Py_;
    for (Eigen::Index r = 0; r < rows_; ++r) {
      const double wa = w(axis_of_row_(r));
      C->row(r) *= wa;
      (*z)(r) *= wa;
    }
  }

  /// The projected residual (compressed: R_a (e_y - M_a theta) per axis) and theta for the tilt in nl.
  LinearSolution solve(const NonlinearParams& nl, const Vec6& w) const {
    Eigen::MatrixXd C;
    Eigen::VectorXd z;
    compressed(model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad), w, &C, &z);
    return solveLinear(C, z);
  }

  /// Mixing matrices of the joint Jacobian of axis a: B_a * mix = [A_a(g_B), dA_a theta(dg_u), dA_a theta(dg_v)]
  /// (unweighted), and the measurement's column e_y. dg_u, dg_v are the derivatives of g_B.
  Eigen::MatrixXd jacobianMix(int a, const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                              const Eigen::VectorXd& theta) const {
    const auto& map = col_[static_cast<std::size_t>(a)];
    const int ca = static_cast<int>(b_cols_[static_cast<std::size_t>(a)]);
    Eigen::MatrixXd mix = Eigen::MatrixXd::Zero(ca, p_ + 2);
    for (int j = 0; j < p_; ++j) {
      const int c0 = map[static_cast<std::size_t>(j)];
      if (c0 >= 0) mix(c0, j) += 1.0;
      for (int k = 0; k < 3; ++k) {
        const int ck = map[static_cast<std::size_t>((k + 1) * p_ + j)];
        if (ck < 0) continue;
        mix(ck, j) += g_B(k) / kStandardGravity;
        mix(ck, p_) += dg_u(k) / kStandardGravity * theta(j);
        mix(ck, p_ + 1) += dg_v(k) / kStandardGravity * theta(j);
      }
    }
    return mix;
  }

  /// Weighted joint Jacobian, compressed (rows() x (p + 2)): same column norms, singular values and
  /// (J^T J)^{-1} as the stacked one.
  Eigen::MatrixXd compressedJacobian(const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                     const Eigen::VectorXd& theta, const Vec6& w) const {
    Eigen::MatrixXd J(rows_, p_ + 2);
    for (int a = 0; a < 6; ++a) {
      const auto& Ra = R_[static_cast<std::size_t>(a)];
      J.middleRows(offset_[static_cast<std::size_t>(a)], Ra.rows()) = w(a) * Ra * jacobianMix(a, g_B, dg_u, dg_v, theta);
    }
    return J;
  }

  /// Per-axis sums of squares of the unweighted residual w_i - Y_i(g_B) theta over the samples,
  /// |B_a v|^2 = |R_a v|^2 (R_a^T R_a = B_a^T B_a): no pass over the rows. The Gram factor holds
  /// y_a's part outside the columns to the rounding of the Gram sums (blocks of 256 rows, then the
  /// blocks in turn: ~(256 + N/256) eps |y_a|^2, about 1e-14 |y_a|^2 at 10,001 samples), so a sum
  /// is exact to that relative to itself (1e-8 at a signal-to-noise power ratio of 1e6): ample for
  /// the axis weights it sets (the fit's residual, sigma^2 and scores come from the rows).
  Vec6 residualSquares(const Vec3& g_B, const Eigen::VectorXd& theta) const {
    Vec6 ss;
    for (int a = 0; a < 6; ++a) ss(a) = (R_[static_cast<std::size_t>(a)] * residualMix(a, g_B, theta)).squaredNorm();
    return ss;
  }

  /// Newey-West scores (N x (p + 2), row i = sum_a J_(6i+a)^T r_(6i+a) of the weighted joint
  /// Jacobian and residual) and the unweighted residual (6 x N), in one pass over the rows of B_a:
  /// the Jacobian rows of axis a are w_a B_a(i, :) mix_a, so s_i = sum_a w_a^2 r_a(i) B_a(i, :) mix_a
  /// with r_a(i) = B_a(i, :) v_a. mix_a is sparse: column bc of B_a (A0 or E_k of theta_j) feeds
  /// score column j with weight 1 or g_B(k) / s, and the two tilt columns through the dense
  /// vectors mix_a(:, p) and mix_a(:, p + 1). So a row costs three dot products of length c_a and
  /// one product per score column it feeds (the columns of B_a feeding theta_j summed first: a
  /// store per score column, no chain of stores to one column).
  /// The scores live in this object's scratch (valid while it lives, until the next call).
  Eigen::Map<const Eigen::MatrixXd> scores(const Vec3& g_B, const Vec3& dg_u, const Vec3& dg_v,
                                           const Eigen::VectorXd& theta, const Vec6& w,
                                           Mat6X* residual_unweighted) {
    const Eigen::Index n = n_;
    const Eigen::Index k = p_ + 2;
    Eigen::Map<Eigen::MatrixXd> S(data_ + s_offset_, n, k);
    residual_unweighted->resize(6, n);
    std::array<Eigen::Matrix<double, Eigen::Dynamic, 3>, 6> dots;  // columns v_a, mix_a(:, p), mix_a(:, p + 1)
    struct Feed {
      Eigen::Index to;     ///< score column j < p
      Eigen::Index first;  ///< its terms in from/weight
      Eigen::Index count;
    };
    std::array<std::vector<Feed>, 6> feeds;
    std::array<std::vector<Eigen::Index>, 6> from;  // columns of B_a, grouped by the score column they feed
    std::array<std::vector<double>, 6> weight;      // their mix_a entries
    for (int a = 0; a < 6; ++a) {
      const std::size_t ua = static_cast<std::size_t>(a);
      const Eigen::MatrixXd mix = jacobianMix(a, g_B, dg_u, dg_v, theta);
      const Eigen::Index ca = mix.rows();
      dots[ua].resize(ca, 3);
      dots[ua].col(0) = residualMix(a, g_B, theta);
      dots[ua].col(1) = mix.col(p_);
      dots[ua].col(2) = mix.col(p_ + 1);
      for (Eigen::Index j = 0; j < p_; ++j) {
        const Eigen::Index first = static_cast<Eigen::Index>(from[ua].size());
        for (Eigen::Index bc = 0; bc < ca; ++bc) {
          if (mix(bc, j) == 0.0) continue;
          from[ua].push_back(bc);
          weight[ua].push_back(mix(bc, j));
        }
        const Eigen::Index count = static_cast<Eigen::Index>(from[ua].size()) - first;
        if (count > 0) feeds[ua].push_back({j, first, count});
      }
    }
    // Blocks of rows (scores row-major: a sample's k entries together, copied into S's columns);
    // from kParallelSamples on the second half of the blocks on a thread of its own (rows of S
    // and of the residual are the samples': the halves write apart).
    constexpr Eigen::Index kBlock = 256;
    auto runBlocks = [&](Eigen::Index begin, Eigen::Index end) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> T(kBlock, k);
      for (Eigen::Index i0 = begin; i0 < end; i0 += kBlock) {
        const Eigen::Index len = std::min(kBlock, end - i0);
        T.topRows(len).setZero();
        for (int a = 0; a < 6; ++a) {
          const std::size_t ua = static_cast<std::size_t>(a);
          const Eigen::Index ca = b_cols_[ua];
          const double* v = dots[ua].col(0).data();
          const double* mu = dots[ua].col(1).data();
          const double* mv = dots[ua].col(2).data();
          const std::vector<Feed>& fa = feeds[ua];
          const Eigen::Index* f = from[ua].data();
          const double* m = weight[ua].data();
          const double w2 = w(a) * w(a);
          const double* row = rowOf(a, i0);
          for (Eigen::Index i = 0; i < len; ++i, row += ca) {
            double r = 0.0, du = 0.0, dv = 0.0;
            for (Eigen::Index c = 0; c < ca; ++c) {
              r += row[c] * v[c];
              du += row[c] * mu[c];
              dv += row[c] * mv[c];
            }
            (*residual_unweighted)(a, i0 + i) = r;
            const double q = w2 * r;
            double* t = T.data() + i * k;
            t[p_] += q * du;
            t[p_ + 1] += q * dv;
            for (const Feed& feed : fa) {
              double sum = 0.0;
              for (Eigen::Index e = feed.first; e < feed.first + feed.count; ++e) sum += m[e] * row[f[e]];
              t[feed.to] += q * sum;
            }
          }
        }
        S.middleRows(i0, len) = T.topRows(len);
      }
    };
    const Eigen::Index mid = n >= kParallelSamples ? ((n / 2 + kBlock - 1) / kBlock) * kBlock : n;
    if (mid >= n || !internal::runConcurrently([&] { runBlocks(mid, n); }, [&] { runBlocks(0, mid); })) runBlocks(0, n);
    return {S.data(), n, k};
  }

  Eigen::Index rows() const { return rows_; }

 private:
  /// v with B_a v = y_a - A_a(g_B) theta.
  Eigen::VectorXd residualMix(int a, const Vec3& g_B, const Eigen::VectorXd& theta) const {
    const auto& map = col_[static_cast<std::size_t>(a)];
    Eigen::VectorXd v = Eigen::VectorXd::Zero(b_cols_[static_cast<std::size_t>(a)]);
    v(map[static_cast<std::size_t>(4 * p_)]) = 1.0;
    for (int j = 0; j < p_; ++j) {
      const int c0 = map[static_cast<std::size_t>(j)];
      if (c0 >= 0) v(c0) -= theta(j);
      for (int k = 0; k < 3; ++k) {
        const int ck = map[static_cast<std::size_t>((k + 1) * p_ + j)];
        if (ck >= 0) v(ck) -= g_B(k) / kStandardGravity * theta(j);
      }
    }
    return v;
  }

  int p_ = 0;
  bool gram_ = false;
  /// Row-major: a sample's row is written at once (column-major, its c_a entries would sit on c_a
  /// pages, N * 8 bytes apart).
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<RowMatrix> rowsOf(int a) {
    return {data_ + b_offset_[static_cast<std::size_t>(a)], n_, b_cols_[static_cast<std::size_t>(a)]};
  }
  Eigen::Map<const RowMatrix> rowsOf(int a) const {
    return {data_ + b_offset_[static_cast<std::size_t>(a)], n_, b_cols_[static_cast<std::size_t>(a)]};
  }
  double* rowOf(int a, Eigen::Index i) {
    return data_ + b_offset_[static_cast<std::size_t>(a)] + i * b_cols_[static_cast<std::size_t>(a)];
  }
  ThreadScratch scratch_;
  double* data_ = nullptr;                   ///< the scratch: B_a per axis (N x c_a, row-major), scores
  Eigen::Index n_ = 0;                       ///< samples (rows of B_a)
  std::array<Eigen::Index, 6> b_cols_{};     ///< c_a
  std::array<std::size_t, 6> b_offset_{};    ///< first double of B_a in data_
  std::size_t s_offset_ = 0;                 ///< first double of the scores in data_
  std::array<Eigen::MatrixXd, 6> G_;         ///< per axis, B_a^T B_a (lower triangle)
  std::array<Eigen::MatrixXd, 6> R_;         ///< per axis, R_a^T R_a = B_a^T B_a (c_a or min(N, c_a) rows)
  std::array<std::vector<int>, 6> col_;      ///< (k p + j) or 4p (y) -> column of B_a, or -1
  std::array<std::vector<int>, 6> src_;      ///< column of B_a (not y) -> entry 6 (k p + j) + a of Y4
  std::array<Eigen::Index, 6> offset_{};     ///< first stacked row of each axis
  Eigen::Index rows_ = 0;
  std::array<Eigen::MatrixXd, 4> P_;         ///< stacked R columns of A0, E0, E1, E2
  Eigen::VectorXd Py_;                       ///< stacked R column of y
  Eigen::VectorXi axis_of_row_;
  bool force_stage_ = false;                 ///< B_a holds the static force stage's data (initialTilt)
  int c_mass_ = -1;
  int c_f0_[3] = {-1, -1, -1};
};

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

struct PhiState {
  Eigen::VectorXd phi;
  NonlinearParams fixed;  ///< values of the parameters the model does not estimate
  int iterations = 0;
  NonlinearParams params(const PhiLayout& L) const { return L.params(phi, fixed); }
};

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

Mat6X unstack(const Eigen::VectorXd& v, int n) {
  return Eigen::Map<const Mat6X>(v.data(), 6, n);
}

void checkTimeOrder(const Problem& pb) {
  for (int i = 1; i < pb.n; ++i) {
    if (!(pb.at(i).t > pb.at(i - 1).t)) {
      throw DataError("model with sensor_delay: sample " + std::to_string(pb.indices[static_cast<std::size_t>(i)]) +
                      " (t = " + std::to_string(pb.at(i).t) +
                      " s) is not later than the one before it; a delay needs a time series");
    }
  }
}

/// A static pose set (noise.hpp, poseGroups: the robot at rest) cannot show a delay: the reading
/// does not change while a pose is held, and the jump between poses is not motion that the
/// kinematics describe. Refuse rather than report a number.
void checkNotStatic(const Problem& pb, const Model& model) {
  std::vector<SampleContext> subset;
  subset.reserve(static_cast<std::size_t>(pb.n));
  for (int i = 0; i < pb.n; ++i) subset.push_back(pb.at(i));
  bool is_static = false;
  (void)poseGroups(subset, &is_static);
  if (is_static) {
    throw IdentificationError("model '" + model.name() +
                              "' estimates a sensor delay, but the log is a static pose set (the robot is at "
                              "rest): a delay shows only while the wrench changes with the motion; fit it on an "
                              "excitation run, or leave sensor_delay out");
  }
}

std::vector<std::string> paramNames(const Model& model) { return model.paramIndex().names(); }

}  // namespace

Mat6X timeDerivative(const std::vector<double>& t, const Mat6X& w, const std::vector<int>& segment_start) {
  const int n = static_cast<int>(w.cols());
  Mat6X d = Mat6X::Zero(6, n);
  std::vector<int> starts = segment_start;
  if (starts.empty()) starts.push_back(0);
  starts.push_back(n);
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    const int a0 = starts[s];
    const int a1 = starts[s + 1];
    for (int i = a0; i < a1; ++i) {
      const int a = std::max(i - 1, a0);
      const int b = std::min(i + 1, a1 - 1);
      const double dt = t[static_cast<std::size_t>(b)] - t[static_cast<std::size_t>(a)];
      if (b > a && dt > 0.0) d.col(i) = (w.col(b) - w.col(a)) / dt;
    }
  }
  return d;
}

bool initialTilt(const std::vector<SampleContext>& contexts, const std::vector<int>& indices, double* tilt_u_rad,
                 double* tilt_v_rad) {
  bool all = indices.size() == contexts.size();  // all contexts in order: no copy
  for (std::size_t k = 0; all && k < indices.size(); ++k) all = indices[k] == static_cast<int>(k);
  std::vector<SampleContext> subset;
  if (!all) {
    subset.reserve(indices.size());
    for (int idx : indices) subset.push_back(contexts[static_cast<std::size_t>(idx)]);
  }
  try {
    PaperOptions po;
    po.method = PaperMethod::kStatic;
    const PaperResult pr = identifyPaper(all ? contexts : subset, po);
    *tilt_u_rad = pr.tilt_u_rad;
    *tilt_v_rad = pr.tilt_v_rad;
    return true;
  } catch (const Error&) {
    return false;
  }
}

double initialDelayEstimate(const std::vector<double>& t, const Mat6X& measured, const Mat6X& pred,
                            const Vec6& w, double max_delay_s) {
  const int n = static_cast<int>(t.size());
  if (n < 3 || measured.cols() != n || pred.cols() != n) return 0.0;
  const double t0 = t.front();
  const double t1 = t.back();
  auto cost = [&](double tau) {
    double sse = 0.0;
    int count = 0;
    int k = 0;
    for (int i = 0; i < n; ++i) {
      const double ts = t[static_cast<std::size_t>(i)] - tau;
      if (ts < t0 || ts > t1) continue;
      while (k + 1 < n - 1 && t[static_cast<std::size_t>(k + 1)] <= ts) ++k;
      while (k > 0 && t[static_cast<std::size_t>(k)] > ts) --k;
      const int k1 = std::min(k + 1, n - 1);
      const double dt = t[static_cast<std::size_t>(k1)] - t[static_cast<std::size_t>(k)];
      const double s = dt > 0.0 ? std::clamp((ts - t[static_cast<std::size_t>(k)]) / dt, 0.0, 1.0) : 0.0;
      const Vec6 m = (1.0 - s) * pred.col(k) + s * pred.col(k1);
      sse += w.cwiseProduct(measured.col(i) - m).squaredNorm();
      ++count;
    }
    // Shifts that keep too little of the data are not trusted.
    return count >= std::max(8, n / 4) ? sse / count : std::numeric_limits<double>::infinity();
  };
  // First-order estimate: residual ~ -tau dw/dt (central differences).
  double num = 0.0;
  double den = 0.0;
  const Mat6X dpred = timeDerivative(t, pred);
  for (int i = 0; i < n; ++i) {
    const Vec6 d = -w.cwiseProduct(dpred.col(i));
    const Vec6 r = w.cwiseProduct(measured.col(i) - pred.col(i));
    num += d.dot(r);
    den += d.squaredNorm();
  }
  double best = 0.0;
  double best_cost = cost(0.0);
  auto consider = [&](double tau) {
    if (!(std::abs(tau) <= max_delay_s)) return;
    const double c = cost(tau);
    if (c < best_cost) {
      best_cost = c;
      best = tau;
    }
  };
  if (den > 0.0) consider(num / den);
  const double dt_mean = (t1 - t0) / (n - 1);
  const double h = std::max(dt_mean, max_delay_s / 200.0);
  const int steps = static_cast<int>(std::ceil(max_delay_s / h));
  for (int s = -steps; s <= steps; ++s) consider(s * h);
  const double center = best;
  for (int s = -10; s <= 10; ++s) consider(center + s * h / 10.0);
  return best;
}

effects::NonlinearParams FitResult::nonlinear() const {
  effects::NonlinearParams p;
  p.tilt_u_rad = tilt_u_rad;
  p.tilt_v_rad = tilt_v_rad;
  p.mount_rpy_rad = mount_rpy_rad;
  p.delay_s = delay_s;
  return p;
}

double FitResult::value(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.value;
  }
  if (name == "tilt_u") return tilt_u_rad;
  if (name == "tilt_v") return tilt_v_rad;
  for (int k = 0; k < 3; ++k) {
    if (mounting_estimated && name == effects::kMountParamNames[k]) return mount_rpy_rad(k);
  }
  if (delay_estimated && name == effects::kDelayParamName) return delay_s;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

double FitResult::stddev(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta_std(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.std;
  }
  if (name == "tilt_u") return tilt_u_std;
  if (name == "tilt_v") return tilt_v_std;
  for (int k = 0; k < 3; ++k) {
    if (mounting_estimated && name == effects::kMountParamNames[k]) return mount_rpy_std(k);
  }
  if (delay_estimated && name == effects::kDelayParamName) return delay_std;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

bool FitResult::has(const std::string& name) const {
  try {
    (void)value(name);
    return true;
  } catch (const std::out_of_range&) {
    return false;
  }
}

FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const FitOptions& options) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return fitModel(model, contexts, all, options);
}

FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const std::vector<int>& indices, const FitOptions& options) {
  Problem pb(model, contexts, indices);
  const PhiLayout L(model);
  const bool estimate_tilt = L.tilt >= 0;
  pb.override_gravity = estimate_tilt || (options.tilt_u_rad && options.tilt_v_rad);
  for (int idx : indices) {
    if (idx < 0 || static_cast<std::size_t>(idx) >= contexts.size()) {
      throw std::out_of_range("fitModel: sample index " + std::to_string(idx) + " out of range");
    }
  }
  const int n_unknowns = pb.p + L.size;
  if (pb.p == 0) throw IdentificationError("model '" + model.name() + "' has no parameters to fit");
  if (6 * pb.n < n_unknowns + 1) {
    throw IdentificationError("too few samples: " + std::to_string(pb.n) + " samples give " +
                              std::to_string(6 * pb.n) + " equations for " +
                              std::to_string(n_unknowns) + " unknowns of model '" + model.name() + "'");
  }
  // Tilt-only models try the compressed tilt search (GravityCompression), whose pass over the data
  // checks them for non-finite values as well.
  const bool try_compressed = options.compressed_tilt_search && L.tilt >= 0 && L.size == 2 && !pb.reads_wmodel;
  if (!try_compressed) checkFinite(pb);
  if (pb.delay) checkTimeOrder(pb);
  if (pb.delay) checkNotStatic(pb, model);
  if (pb.delay && !(options.max_delay_s > 0.0 && std::isfinite(options.max_delay_s))) {
    throw ConfigError("fit: the delay search range must be positive (got " + std::to_string(options.max_delay_s) + " s)");
  }
  // The stacked and the 6 x n measurement: the general path's (the compressed search holds the
  // measurement in its per-axis rows and needs neither).
  Mat6X measured;
  auto copyMeasurement = [&]() {
    pb.y.resize(6 * pb.n);
    measured.resize(6, pb.n);
    for (int i = 0; i < pb.n; ++i) {
      pb.y.segment<6>(6 * i) = pb.at(i).wrench_S;
      measured.col(i) = pb.at(i).wrench_S;
    }
  };
  // First pass of models that read the modelled wrench: wrench_model_S = 0, so their columns
  // vanish and the solve is the other effects' fit with E = 0 (a calibration error is small; the
  // measured wrench as a stand-in is an errors-in-variables start that can end in a false minimum).
  if (pb.reads_wmodel) pb.wmodel = std::vector<Wrench>(static_cast<std::size_t>(pb.n), Wrench::Zero());

  // Initial nonlinear parameters.
  PhiState st;
  st.fixed.tilt_u_rad = options.tilt_u_rad.value_or(0.0);
  st.fixed.tilt_v_rad = options.tilt_v_rad.value_or(0.0);
  if (options.mount_rpy_rad) st.fixed.mount_rpy_rad = *options.mount_rpy_rad;
  const bool tilt_given = options.tilt_u_rad && options.tilt_v_rad;

  // Tilt-only models: the compressed tilt search (GravityCompression), unless the regressor turns
  // out not to be affine in gravity (checked at the given tilt, else at a generic off-axis gravity).
  GravityCompression gc;
  const bool compressed =
      try_compressed &&
      gc.build(pb, model::gravityInBase(tilt_given ? st.fixed.tilt_u_rad : 0.3, tilt_given ? st.fixed.tilt_v_rad : -0.2));
  if (try_compressed && !compressed) checkFinite(pb);
  const GravityCompression* gcp = compressed ? &gc : nullptr;
  if (!compressed) copyMeasurement();
  // The start: the paper's static force stage (not determinable: start level; the rank check below
  // decides). The compressed search solves it on its own data (the same problem, no second pass).
  auto startTilt = [&]() {
    if (!estimate_tilt || tilt_given) return;
    st.fixed.tilt_u_rad = 0.0;
    st.fixed.tilt_v_rad = 0.0;
    if (!compressed || !gc.initialTilt(PaperOptions().rank_tolerance, &st.fixed.tilt_u_rad, &st.fixed.tilt_v_rad)) {
      (void)initialTilt(contexts, indices, &st.fixed.tilt_u_rad, &st.fixed.tilt_v_rad);
    }
  };
  if (compressed) gc.factor(true);
  startTilt();
  st.phi = L.vector(st.fixed);

  const std::vector<std::string> names = paramNames(model);
  // Rank of the linear part at the initial point (the measured wrench stands in for the modelled
  // one of the effects that read it).
  {
    if (pb.reads_wmodel) {
      for (int i = 0; i < pb.n; ++i) pb.wmodel[static_cast<std::size_t>(i)] = measured.col(i);
    }
    Eigen::MatrixXd A;
    auto rankAtStart = [&]() {
      if (compressed) {
        // Same column norms and singular values as the stacked regressor.
        Eigen::VectorXd z;
        const NonlinearParams nl0 = st.params(L);
        gc.compressed(model::gravityInBase(nl0.tilt_u_rad, nl0.tilt_v_rad), Vec6::Ones(), &A, &z);
      } else {
        pb.buildRegressor(st.params(L), Vec6::Ones(), &A);
      }
      return internal::analyzeRank(A, options.rank_tolerance);
    };
    internal::RankReport rr = rankAtStart();
    if (compressed && (rr.rank < pb.p || rr.condition_number > kGramConditionLimit)) {
      // Too ill-conditioned for the Gram factor (or rank-deficient: decide on the exact one).
      gc.factor(false);
      startTilt();
      st.phi = L.vector(st.fixed);
      rr = rankAtStart();
    }
    if (rr.rank < pb.p) {
      std::vector<std::string> bad;
      for (int j : rr.unexcited_columns) bad.push_back(names[static_cast<std::size_t>(j)]);
      throw IdentificationError("the data do not determine " + internal::joinNames(bad) +
                                " of model '" + model.name() + "' (rank " + std::to_string(rr.rank) +
                                " of " + std::to_string(pb.p) +
                                "): excite them with more distinct orientations/motions");
    }
  }

  if (pb.reads_wmodel) std::fill(pb.wmodel.begin(), pb.wmodel.end(), Wrench::Zero());

  Vec6 weights = Vec6::Ones();
  LinearSolution sol;
  double delay_lo = -1e300;
  double delay_hi = 1e300;
  const double dt_mean = pb.n > 1 ? (pb.at(pb.n - 1).t - pb.at(0).t) / (pb.n - 1) : 0.0;
  auto setDelayWindow = [&](double center) {
    const double margin = std::max(0.02 * options.max_delay_s, 4.0 * dt_mean);
    delay_lo = std::max(-options.max_delay_s, center - margin);
    delay_hi = std::min(options.max_delay_s, center + margin);
    pb.setActiveWindow(delay_lo, delay_hi);
    if (6 * pb.n_active < n_unknowns + 1) {
      throw IdentificationError("a delay of " + std::to_string(center) + " s leaves too few samples (" +
                                std::to_string(pb.n_active) + ") inside the log");
    }
  };
  // Weighted sum of squares of the true model (effects::ModelEvaluator) over the active samples.
  auto trueCost = [&](const Eigen::VectorXd& theta, const NonlinearParams& nl) {
    const Mat6X r = measured - pb.predict(theta, nl);
    double sse = 0.0;
    for (int i = 0; i < pb.n; ++i) {
      if (pb.active[static_cast<std::size_t>(i)]) sse += weights.cwiseProduct(r.col(i)).squaredNorm();
    }
    return sse;
  };
  auto runFit = [&](int derivative_passes, int iterations) {
    pb.gn_lambda = 0.0;
    sol = fitNonlinear(pb, L, weights, iterations, &st, delay_lo, delay_hi, gcp);
    if (derivative_passes == 0) return;
    // Levenberg-damped Gauss-Newton passes on the modelled-wrench effects (Problem::gn_theta),
    // each accepted only if the true (bilinear) model's cost falls.
    double cost = trueCost(sol.theta, st.params(L));
    double lambda = 1e-4;
    for (int k = 0; k < 4 * derivative_passes && lambda < 1e8; ++k) {
      const LinearSolution saved_sol = sol;
      const PhiState saved_st = st;
      pb.wmodel = pb.basePrediction(sol.theta, st.params(L));
      pb.gn_theta = sol.theta;
      pb.gn_lambda = lambda;
      // The passes themselves iterate: a couple of nonlinear steps per pass suffice.
      sol = fitNonlinear(pb, L, weights, std::min(iterations, 2), &st, delay_lo, delay_hi);
      const double trial = trueCost(sol.theta, st.params(L));
      if (trial <= cost) {
        const double change = cost - trial;
        cost = trial;
        lambda = std::max(lambda * 0.1, 1e-12);
        if (change <= 1e-10 * cost) break;
      } else {
        sol = saved_sol;
        st = saved_st;
        lambda *= 10.0;
      }
    }
    // Leave the linearisation at the solution, undamped (the Jacobian and covariance use it).
    pb.wmodel = pb.basePrediction(sol.theta, st.params(L));
    pb.gn_theta = sol.theta;
    pb.gn_lambda = 0.0;
    Eigen::VectorXd r(6 * pb.n);
    const Mat6X m = pb.predict(sol.theta, st.params(L));
    for (int i = 0; i < pb.n; ++i) {
      r.segment<6>(6 * i) = pb.active[static_cast<std::size_t>(i)]
                                ? Vec6(weights.cwiseProduct(measured.col(i) - m.col(i)))
                                : Vec6::Zero();
    }
    sol.residual = r;
  };
  if (pb.delay) {
    // Start: fit everything else with no delay, then scan the delay on that prediction.
    st.phi(L.delay) = 0.0;
    delay_lo = delay_hi = 0.0;
    pb.setActiveWindow(0.0, 0.0);
    runFit(pb.reads_wmodel ? 1 : 0, std::min(options.max_tilt_iterations, 4));
    const Mat6X r0 = unstack(sol.residual, pb.n);
    Vec6 w0 = Vec6::Ones();
    const Vec6 rms0 = (r0.rowwise().squaredNorm() / pb.n).cwiseSqrt();
    const double fl0 = std::max(1e-3 * rms0.maxCoeff(), 1e-12);
    for (int a = 0; a < 6; ++a) w0(a) = 1.0 / std::max(rms0(a), fl0);
    const Mat6X pred0 = pb.predict(sol.theta, st.params(L));
    std::vector<double> times(static_cast<std::size_t>(pb.n));
    for (int i = 0; i < pb.n; ++i) times[static_cast<std::size_t>(i)] = pb.at(i).t;
    const double tau0 = initialDelayEstimate(times, measured, pred0, w0, options.max_delay_s);
    st.phi(L.delay) = tau0;
    setDelayWindow(tau0);
  }
  // The unweighted pass only has to give the per-axis residual RMS for the weights: a few
  // iterations suffice; the weighted pass then converges fully from there.
  runFit(pb.reads_wmodel ? options.derivative_iterations : 0,
         options.axis_weights ? std::min(options.max_tilt_iterations, 4) : options.max_tilt_iterations);
  if (options.axis_weights) {
    // Compressed: the per-axis sums of squares from the factor (GravityCompression::residualSquares).
    const Vec6 ss = compressed ? gc.residualSquares(model::gravityInBase(st.params(L).tilt_u_rad, st.params(L).tilt_v_rad),
                                                    sol.theta)
                               : Vec6(unstack(sol.residual, pb.n).rowwise().squaredNorm());
    const Vec6 rms = (ss / std::max(1, pb.n_active)).cwiseSqrt();
    const double floor = std::max(1e-3 * rms.maxCoeff(), 1e-12);
    for (int a = 0; a < 6; ++a) weights(a) = 1.0 / std::max(rms(a), floor);
    runFit(pb.reads_wmodel ? 2 : 0, options.max_tilt_iterations);
  }
  // A delay that ran into its window's edge: move the window and refit (a few times at most).
  for (int k = 0; pb.delay && k < 3; ++k) {
    const double tau = st.phi(L.delay);
    const bool at_edge = (tau <= delay_lo + 1e-12 && delay_lo > -options.max_delay_s) ||
                         (tau >= delay_hi - 1e-12 && delay_hi < options.max_delay_s);
    if (!at_edge) break;
    setDelayWindow(tau);
    runFit(pb.reads_wmodel ? 2 : 0, options.max_tilt_iterations);
  }
  const NonlinearParams nl = st.params(L);

  FitResult res;
  res.model_name = model.name();
  res.params = model.params();
  res.theta = sol.theta;
  res.tilt_estimated = estimate_tilt;
  res.tilt_applied = pb.override_gravity;
  res.tilt_u_rad = pb.override_gravity ? nl.tilt_u_rad : 0.0;
  res.tilt_v_rad = pb.override_gravity ? nl.tilt_v_rad : 0.0;
  res.mounting_estimated = pb.mounting;
  res.mount_rpy_rad = pb.mounting ? nl.mount_rpy_rad : Vec3::Zero();
  res.delay_estimated = pb.delay;
  res.delay_s = pb.delay ? nl.delay_s : 0.0;
  res.n_excluded = pb.n - pb.n_active;
  res.tilt_iterations = st.iterations;
  res.axis_weights = weights;
  res.n_samples = pb.n_active;

  // Joint Jacobian of the weighted model wrt [theta, phi] at the solution (and the weighted
  // residual per sample, for the Newey-West scores).
  Eigen::MatrixXd J;
  Eigen::MatrixXd J_weighted;
  Eigen::VectorXd r_weighted;
  // Compressed: the Newey-West scores directly (no 6N-row Jacobian), in gc's scratch.
  std::optional<Eigen::Map<const Eigen::MatrixXd>> scores;
  Mat6X residual_compressed;  // compressed: the unweighted residual from the rows of B_a
  // Compressed J for the rank, condition number and (J^T J)^{-1}; the per-sample rows from B_a.
  // Tilt columns: central differences of g_B (the regressor is affine in it), as below.
  const double h_tilt = 1e-5;
  const Vec3 g_B = model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad);
  const Vec3 dg_u = (model::gravityInBase(nl.tilt_u_rad + h_tilt, nl.tilt_v_rad) -
                     model::gravityInBase(nl.tilt_u_rad - h_tilt, nl.tilt_v_rad)) / (2.0 * h_tilt);
  const Vec3 dg_v = (model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad + h_tilt) -
                     model::gravityInBase(nl.tilt_u_rad, nl.tilt_v_rad - h_tilt)) / (2.0 * h_tilt);
  if (compressed) {
    J = gc.compressedJacobian(g_B, dg_u, dg_v, sol.theta, weights);
    scores.emplace(gc.scores(g_B, dg_u, dg_v, sol.theta, weights, &residual_compressed));
  } else {
    J.resize(6 * pb.n, n_unknowns);
    Eigen::MatrixXd A;
    pb.buildRegressor(nl, weights, &A);
    J.leftCols(pb.p) = A;
    Eigen::MatrixXd Ap, Am;
    for (int j = 0; j < L.size; ++j) {
      const double h = j == L.delay ? std::max(1e-5, 0.05 * dt_mean) : 1e-5;
      PhiState sp = st;
      PhiState sm = st;
      sp.phi(j) += h;
      sm.phi(j) -= h;
      pb.buildRegressor(sp.params(L), weights, &Ap);
      pb.buildRegressor(sm.params(L), weights, &Am);
      J.col(pb.p + j) = (Ap - Am) * sol.theta / (2.0 * h);
    }
    J_weighted = J;  // the QR factors J in place; the covariance needs it
    r_weighted = sol.residual;
  }
  std::vector<std::string> all_names = names;
  if (L.tilt >= 0) {
    all_names.push_back("tilt_u");
    all_names.push_back("tilt_v");
  }
  if (L.mount >= 0) {
    for (const char* m : effects::kMountParamNames) all_names.push_back(m);
  }
  if (L.delay >= 0) all_names.push_back(effects::kDelayParamName);
  // One factorisation of J for the rank check, the condition number and the covariance.
  std::optional<internal::ScaledQR> qr_j_storage;
  qr_j_storage.emplace(J, options.rank_tolerance);
  if (compressed && gc.gram() &&
      (qr_j_storage->rank().rank < n_unknowns || qr_j_storage->rank().condition_number > kGramConditionLimit)) {
    // The start's check saw only theta's columns: with the tilt's, J is too ill-conditioned for the
    // Gram factor (or rank-deficient: name the columns from the exact one). Householder QR instead.
    qr_j_storage.reset();
    gc.factor(false);
    J = gc.compressedJacobian(g_B, dg_u, dg_v, sol.theta, weights);
    qr_j_storage.emplace(J, options.rank_tolerance);
  }
  const internal::ScaledQR& qr_j = *qr_j_storage;
  const internal::RankReport& rr = qr_j.rank();
  if (rr.rank < n_unknowns) {
    std::vector<std::string> bad;
    for (int j : rr.unexcited_columns) bad.push_back(all_names[static_cast<std::size_t>(j)]);
    throw IdentificationError("the data do not determine " + internal::joinNames(bad) + " of model '" +
                              model.name() + "' (rank " + std::to_string(rr.rank) + " of " +
                              std::to_string(n_unknowns) +
                              "): excite them with more distinct orientations/motions");
  }
  res.condition_number = rr.condition_number;
  const int dof = 6 * pb.n_active - n_unknowns;
  // Autocorrelation-robust (Newey-West) covariance: holds for filtered noise (uncertainty.hpp).
  if (compressed) {
    // The same sandwich from the scores (robustCovariance is scoreCovariance of J's scores).
    const Mat6X r_w = weights.asDiagonal() * residual_compressed;
    res.sigma2 = dof > 0 ? r_w.squaredNorm() / dof : 0.0;
    res.covariance = scoreCovariance(*scores, r_w, qr_j.inverseGram()).covariance;
  } else {
    res.sigma2 = dof > 0 ? sol.residual.squaredNorm() / dof : 0.0;
    res.covariance = robustCovariance(J_weighted, r_weighted, qr_j.inverseGram()).covariance;
  }
  res.theta_std = res.covariance.diagonal().head(pb.p).cwiseMax(0.0).cwiseSqrt();
  auto sd = [&](int j) { return std::sqrt(std::max(res.covariance(pb.p + j, pb.p + j), 0.0)); };
  if (L.tilt >= 0) {
    res.tilt_u_std = sd(L.tilt);
    res.tilt_v_std = sd(L.tilt + 1);
  }
  if (L.mount >= 0) {
    for (int k = 0; k < 3; ++k) res.mount_rpy_std(k) = sd(L.mount + k);
  }
  if (L.delay >= 0) res.delay_std = sd(L.delay);

  // Unweighted residual (the compensator's evaluation; compressed: the same model from the rows of
  // B_a, affine in g_S); excluded samples count as zero.
  res.residual = compressed ? std::move(residual_compressed) : Mat6X(measured - pb.predict(sol.theta, nl));
  for (int i = 0; i < pb.n; ++i) {
    if (!pb.active[static_cast<std::size_t>(i)]) res.residual.col(i).setZero();
  }
  res.residual_rms = (res.residual.rowwise().squaredNorm() / std::max(1, pb.n_active)).cwiseSqrt();

  // Derived parameters: com = mass_com / mass, weight = m g (delta method).
  const auto& index = model.paramIndex();
  const int cm = index.column("mass");
  if (cm >= 0) {
    res.derived.push_back({"weight", kStandardGravity * res.theta(cm),
                           kStandardGravity * res.theta_std(cm), "N"});
    const char* mc_names[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
    const char* com_names[3] = {"com_x", "com_y", "com_z"};
    for (int k = 0; k < 3; ++k) {
      const int cj = index.column(mc_names[k]);
      if (cj < 0) continue;
      const double m = res.theta(cm);
      const double mc = res.theta(cj);
      Eigen::Vector2d grad(-mc / (m * m), 1.0 / m);
      Eigen::Matrix2d C;
      C << res.covariance(cm, cm), res.covariance(cm, cj), res.covariance(cj, cm), res.covariance(cj, cj);
      res.derived.push_back({com_names[k], mc / m, std::sqrt(std::max(grad.dot(C * grad), 0.0)), "m"});
    }
  }
  return res;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       const effects::NonlinearParams& nonlinear,
                                                       bool apply_tilt,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  if (theta.size() != model.numParams()) {
    throw std::invalid_argument("predictWrench: theta has " + std::to_string(theta.size()) +
                                " entries, model '" + model.name() + "' has " +
                                std::to_string(model.numParams()) + " parameters");
  }
  Problem pb(model, contexts, indices);
  pb.override_gravity = apply_tilt;
  if (pb.n == 0) return Mat6X(6, 0);
  return pb.predict(theta, nonlinear);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       std::optional<double> tilt_u_rad,
                                                       std::optional<double> tilt_v_rad,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  effects::NonlinearParams nl;
  nl.tilt_u_rad = tilt_u_rad.value_or(0.0);
  nl.tilt_v_rad = tilt_v_rad.value_or(0.0);
  return predictWrench(model, theta, nl, tilt_u_rad.has_value() && tilt_v_rad.has_value(), contexts, indices);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  return predictWrench(model, fit.theta, fit.nonlinear(), fit.tilt_applied, contexts, indices);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return predictWrench(model, fit, contexts, all);
}

}  // namespace ftid::identify
