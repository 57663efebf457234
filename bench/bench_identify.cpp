// Identification and compensation timing (docs/performance.md, "Identification and compensation").
//   - paper method (dynamic; static as a same-run baseline) on 1,251 and 10,001 samples
//   - fitModel("paper") and fitModel("paper+rigid_body") (variable projection on the tilt, per-axis
//     weights) on the same data: the compressed tilt search vs the general path (baseline)
//   - the stacked linear solve alone: Householder QR (what fitModel uses) vs normal equations
//     (baseline)
//   - Compensator::compute per sample
// Plain std::chrono (and the thread's CPU time), many repetitions, median and p99. Data: f1's simulator, paper cell, noisy.
// Ratios are printed only against a baseline timed in the same run (never against recorded
// figures of an earlier build or machine): earlier implementations are not kept in the binary
// (except fitModel's general path, kept as the reference of the compressed tilt search), so other
// old-vs-new comparisons mean running the old build's bench on the same machine.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

#include "ftid/common/default_files.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

using Clock = std::chrono::steady_clock;

struct Stats {
  double median_us;
  double p99_us;
  double cpu_median_us;  ///< this thread's CPU time (less sensitive to other processes' load)
};

double threadCpuUs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
}

Stats timeIt(int reps, const std::function<void()>& f) {
  f();  // warm-up
  std::vector<double> us;
  std::vector<double> cpu;
  us.reserve(static_cast<std::size_t>(reps));
  cpu.reserve(static_cast<std::size_t>(reps));
  for (int r = 0; r < reps; ++r) {
    const double c0 = threadCpuUs();
    const auto t0 = Clock::now();
    f();
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    cpu.push_back(threadCpuUs() - c0);
  }
  std::sort(us.begin(), us.end());
  std::sort(cpu.begin(), cpu.end());
  const auto p99 = static_cast<std::size_t>(0.99 * static_cast<double>(us.size() - 1) + 0.5);
  return {us[us.size() / 2], us[p99], cpu[cpu.size() / 2]};
}

void report(const std::string& what, int reps, const Stats& s) {
  std::printf("%-58s reps %5d  median %10.1f us  p99 %10.1f us  (CPU median %10.1f us)\n", what.c_str(), reps,
              s.median_us, s.p99_us, s.cpu_median_us);
}

/// Median ratio against a baseline measured in this run.
void ratio(const std::string& what, const Stats& s, const Stats& baseline) {
  std::printf("  %-56s %.2fx (medians, same run)\n", what.c_str(), s.median_us / baseline.median_us);
}

volatile double g_sink = 0.0;

}  // namespace

int main() {
  using namespace ftid;
  const auto kin = model::RobotKinematics::fromUrdfFile(defaultRobotUrdf());
  for (double rate : {125.0, 1000.0}) {
    sim::CellSimConfig cfg = sim::paperCellConfig(kin);
    cfg.rate_hz = rate;
    cfg.full_rigid_body = false;
    cfg.seed = 3;
    cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
    const samples::ContextSet s = samples::buildContexts(sim::CellSim(cfg).run(), kin);
    const std::string n = std::to_string(s.size()) + " samples";
    const bool small = s.size() < 2000;

    int reps = small ? 2000 : 300;
    const Stats dyn = timeIt(reps, [&] { g_sink = identify::identifyPaper(s.samples).weight_N; });
    report("paper dynamic, " + n, reps, dyn);
    identify::PaperOptions st;
    st.method = identify::PaperMethod::kStatic;
    const Stats sta = timeIt(reps, [&] { g_sink = identify::identifyPaper(s.samples, st).weight_N; });
    report("paper static (baseline), " + n, reps, sta);
    ratio("paper dynamic / static", dyn, sta);

    const effects::Model model = effects::Model::fromName("paper");
    // fitModel: the compressed tilt search (the default) and the general path (the previous
    // implementation, FitOptions::compressed_tilt_search = false) as the same-run baseline.
    identify::FitOptions general;
    general.compressed_tilt_search = false;
    for (const char* name : {"paper", "paper+rigid_body"}) {
      const effects::Model m = effects::Model::fromName(name);
      reps = small ? 200 : 40;
      const Stats fast = timeIt(reps, [&] { g_sink = identify::fitModel(m, s.samples).theta(0); });
      report(std::string("fitModel(") + name + "), " + n, reps, fast);
      const int greps = small ? 20 : 5;
      const Stats slow = timeIt(greps, [&] { g_sink = identify::fitModel(m, s.samples, general).theta(0); });
      report(std::string("fitModel(") + name + ") general path (baseline), " + n, greps, slow);
      ratio("compressed / general", fast, slow);
    }

    // The stacked linear problem alone (tilt known): QR vs normal equations.
    Eigen::MatrixXd A(6 * static_cast<Eigen::Index>(s.size()), model.numParams());
    Eigen::VectorXd y(A.rows());
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, model.numParams());
    for (std::size_t i = 0; i < s.size(); ++i) {
      model.computeRegressor(s.samples[i], Y);
      A.middleRows(6 * static_cast<Eigen::Index>(i), 6) = Y;
      y.segment<6>(6 * static_cast<Eigen::Index>(i)) = s.samples[i].wrench_S;
    }
    reps = small ? 500 : 100;
    const Stats qr = timeIt(reps, [&] { g_sink = Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(A).solve(y)(0); });
    report("  linear solve, Householder QR (col-pivoted), " + n, reps, qr);
    const Stats ne = timeIt(reps, [&] {
      const Eigen::MatrixXd AtA = A.transpose() * A;
      g_sink = AtA.ldlt().solve(A.transpose() * y)(0);
    });
    report("  linear solve, normal equations LDLT (baseline), " + n, reps, ne);
    ratio("QR / normal equations", qr, ne);

    if (!small) continue;
    // Per-sample compensation: batches of all samples, divided by the count.
    const params::ParameterSet set = identify::identifyPaper(s.samples).toParameterSet();
    auto benchCompensator = [&](compensate::Compensator& comp, const char* label) {
      std::vector<double> per_sample_ns;
      Wrench contact;
      for (int r = 0; r < 400; ++r) {
        comp.reset();  // the log's time starts again
        const auto t0 = Clock::now();
        for (const auto& ctx : s.samples) {
          (void)comp.compute(ctx, &contact, nullptr);
          g_sink = contact(0);
        }
        per_sample_ns.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count() /
                                static_cast<double>(s.size()));
      }
      // Single calls, for the tail.
      std::vector<double> single_ns;
      for (int r = 0; r < 20; ++r) {
        comp.reset();
        for (const auto& ctx : s.samples) {
          const auto t0 = Clock::now();
          (void)comp.compute(ctx, &contact, nullptr);
          single_ns.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count());
          g_sink = contact(0);
        }
      }
      std::sort(per_sample_ns.begin(), per_sample_ns.end());
      std::sort(single_ns.begin(), single_ns.end());
      std::printf("%-58s median %8.1f ns/sample (batched); single call median %.0f ns, p99 %.0f ns\n", label,
                  per_sample_ns[per_sample_ns.size() / 2], single_ns[single_ns.size() / 2],
                  single_ns[static_cast<std::size_t>(0.99 * static_cast<double>(single_ns.size() - 1))]);
    };
    compensate::Compensator comp(model, params::thetaFor(model, set), params::nonlinearFor(model, set));
    benchCompensator(comp, "Compensator::compute (paper model)");
    // The richest model: every effect that changes the compensation path (crosstalk's inverse,
    // the mounting rotation, a 24 ms delay line) plus the other named effects.
    const effects::Model rich = effects::Model::fromName(
        "paper+rigid_body+cable+temperature_drift+time_drift+crosstalk+mounting+sensor_delay");
    Eigen::VectorXd theta_rich = Eigen::VectorXd::Constant(rich.numParams(), 1e-3);
    theta_rich(rich.paramIndex().column("mass")) = 1.0;
    effects::NonlinearParams nl_rich;
    nl_rich.mount_rpy_rad = Vec3(0.01, 0.02, 0.03);
    nl_rich.delay_s = 0.024;
    compensate::Compensator comp_rich(rich, theta_rich, nl_rich);
    benchCompensator(comp_rich, "Compensator::compute (richest model, 24 ms delay)");
  }
  return 0;
}
