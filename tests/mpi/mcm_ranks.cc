// Every number of several Monte Carlo runs, printed exactly (C99 hexadecimal floating point) by
// rank 0. tests/mpi.cmake runs it as one plain process and under `mpirun -np 2` and `-np 3` with
// different thread counts; the printouts must be identical byte for byte (docs/mpi.md: the same
// bits for any number of ranks and threads). The runs cover what the ranks share differently:
// uneven chunk shares (a rank with no chunk in the short last batch), ranks that own no output,
// the adaptive stopping rule (a maximum over the ranks' outputs), the memory budget's averaged
// batch endpoints (from the start, and switched to in the middle of an adaptive run), tolerance
// counts, point groups and a custom model's output vector.
//   mcm_ranks THREADS
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mpi/ranks.h"
#include "test_mcm_helpers.h"
#include "vlt/mcm.h"
#include "vlt/models.h"

namespace {

using namespace vlt;

std::string text;

void Add(const char* name, double v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s %a\n", name, v);
  text += buf;
}

void Print(const std::string& title, const McmResult& r) {
  // Separate appends: GCC 12 warns (-Wrestrict) on long chains of std::string +.
  text += "== ";
  text += title;
  text += " (";
  text += r.interval_method;
  text += ")\n";
  Add("trials", static_cast<double>(r.trials));
  Add("batches", static_cast<double>(r.batches));
  Add("converged", r.converged ? 1.0 : 0.0);
  for (std::size_t i = 0; i < r.convergence_trials.size(); ++i) {
    Add("convergence.trials", static_cast<double>(r.convergence_trials[i]));
    Add("convergence.ratio", r.convergence_ratio[i]);
  }
  for (const McmOutputResult& o : r.outputs) {
    text += o.name;
    text += '\n';
    for (double v :
         {o.value_at_estimates, o.mean, o.u, o.symmetric.low, o.symmetric.high, o.shortest.low,
          o.shortest.high, o.accuracy.s_mean, o.accuracy.s_u, o.accuracy.s_low, o.accuracy.s_high,
          o.accuracy.delta, o.conformity_probability.value_or(-1.0), o.histogram.low, o.histogram.width,
          static_cast<double>(o.histogram.below), static_cast<double>(o.histogram.above)}) {
      Add(" ", v);
    }
    for (std::int64_t c : o.histogram.counts) Add(" bin", static_cast<double>(c));
  }
  for (const McmPointResult& p : r.points) {
    text += p.name;
    text += '\n';
    for (int i = 0; i < 3; ++i) Add(" mean", p.mean(i));
    for (int i = 0; i < 9; ++i) Add(" cov", p.covariance(i / 3, i % 3));
    Add(" region", p.has_region ? p.coverage_factor : -1.0);
  }
  for (const McmVectorResult& v : r.vectors) {
    text += v.name;
    text += '\n';
    for (Eigen::Index i = 0; i < v.mean.size(); ++i) Add(" mean", v.mean(i));
    for (Eigen::Index i = 0; i < v.covariance.size(); ++i) Add(" cov", v.covariance(i));
    Add(" region", v.has_region ? v.coverage_factor : -1.0);
  }
}

// The spec's estimates, u and distributions (not inlined: GCC 12's -Wrestrict false positive
// on std::string assignments inlined into main).
[[gnu::noinline]] std::vector<UncertainInput> SpecInputs(const ModelInfo& m) {
  std::vector<UncertainInput> inputs(static_cast<std::size_t>(m.num_params));
  for (int k = 0; k < m.num_params; ++k) {
    const QuantityInfo& q = m.params[k];
    inputs[k].name = q.name;
    inputs[k].unit = q.unit;
    inputs[k].group = "parameter";
    inputs[k].estimate = q.default_estimate;
    inputs[k].u = q.default_u;
    inputs[k].distribution = q.default_distribution;
    inputs[k].shape = q.default_shape;
  }
  return inputs;
}

}  // namespace

int main(int argc, char** argv) {
  ranks::Session session(&argc, &argv);
  const int threads = argc > 1 ? std::atoi(argv[1]) : 1;
  try {
    const MeasurementModel model(test::MirrorSetup(true));
    McmJob job;
    job.model = &model;
    job.points = test::SomePoints();
    McmJob one = job;
    one.points.resize(1);

    // Fixed M = 25 000: 3 batches, the last of 2 chunks (with 3 ranks, one rank computes none),
    // 4 point groups over 2 or 3 ranks; a tolerance on P2.y.
    McmSettings fixed = test::Fixed(25'000, 7, threads);
    fixed.tolerances.push_back({4, 0.6 - 20e-6, 0.6 + 20e-6});
    Print("job, fixed M", RunMcm(job, fixed));

    // One point: a single block of outputs, so with 2 or 3 ranks some rank owns none.
    Print("one point, fixed M", RunMcm(one, test::Fixed(20'000, 8, threads)));

    // Adaptive (7.9.4), with a memory budget of 1.5 batches: switches to the averaged batch
    // endpoints after the second batch.
    McmSettings adaptive = test::Fixed(0, 9, threads);
    adaptive.significant_digits = 1;
    adaptive.memory_budget_bytes = 4 * 3 * 4 * 15'000;
    Print("job, adaptive, over the memory budget", RunMcm(job, adaptive));

    // A custom model with an output vector (GUM H.2: R, X, Z) over the budget from the start.
    const ModelInfo* h2 = FindModel("gum_h2_impedance");
    if (h2 == nullptr) throw std::runtime_error("model gum_h2_impedance not built in");
    const std::vector<UncertainInput> inputs = SpecInputs(*h2);
    McmSettings custom = test::Fixed(50'000, 10, threads);
    custom.memory_budget_bytes = 1000;
    Print("custom model, averaged endpoints", RunMcmCustom(*h2, inputs, {}, custom));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mcm_ranks: %s\n", e.what());
    return 1;
  }
  if (ranks::IsRoot()) std::fputs(text.c_str(), stdout);
  return 0;
}
