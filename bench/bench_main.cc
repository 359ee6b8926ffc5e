// vlt_bench main: Google Benchmark's usual command line, plus a summary printed after the run
// with the ratios between benchmarks OF THIS RUN (generated vs automatic differentiation vs
// finite differences, threads) and the performance targets of docs/performance.md.
// The summary goes to stdout after the console table, or to stderr with --benchmark_format=json
// (so that stdout stays valid JSON); --benchmark_format=csv prints no summary.
#include <unistd.h>

#include <cstdarg>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace {

// Forwards everything to the reporter the format asks for and keeps items_per_second per run.
class SummaryReporter : public benchmark::BenchmarkReporter {
 public:
  explicit SummaryReporter(benchmark::BenchmarkReporter* inner) : inner_(inner) {}

  bool ReportContext(const Context& context) override {
    inner_->SetOutputStream(&GetOutputStream());
    inner_->SetErrorStream(&GetErrorStream());
    return inner_->ReportContext(context);
  }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      // With --benchmark_repetitions the median aggregate replaces the single runs.
      if (run.error_occurred) continue;
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name != "median") continue;
      const auto it = run.counters.find("items_per_second");
      // Keyed by the registered name (without /real_time, /iterations:1, ... suffixes).
      if (it != run.counters.end()) rate_[run.run_name.function_name] = it->second.value;
    }
    inner_->ReportRuns(runs);
  }
  void Finalize() override { inner_->Finalize(); }

  // items/s of a benchmark of this run, 0 if it did not run (filtered out or failed).
  double Rate(const std::string& name) const {
    const auto it = rate_.find(name);
    return it == rate_.end() ? 0.0 : it->second;
  }

 private:
  benchmark::BenchmarkReporter* inner_;
  std::map<std::string, double> rate_;
};

// printf-style output to a stream (the summary shares std::cout with the console reporter).
void Print(std::ostream& out, const char* format, ...) {
  char buffer[256];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  out << buffer;
}

void Line(std::ostream& out, const char* what, double rate, const char* unit) {
  if (rate > 0.0) Print(out, "  %-58s %10.3f M%s/s\n", what, rate / 1e6, unit);
}

void Ratio(std::ostream& out, const char* what, double num, double den) {
  if (num > 0.0 && den > 0.0) Print(out, "  %-58s %10.1f x\n", what, num / den);
}

void Target(std::ostream& out, const char* what, double value, double target) {
  if (value <= 0.0) return;
  Print(out, "  %-58s %10.2f  (target >= %g): %s\n", what, value, target,
        value >= target ? "met" : "NOT met");
}

void PrintSummary(const SummaryReporter& r, std::ostream& out) {
  const double nominal = r.Rate("gum/generated_nominal/mirror");
  const double fj = r.Rate("gum/generated_forward_jacobians/mirror");
  const double ad = r.Rate("gum/autodiff/mirror");
  const double fd = r.Rate("gum/finite_diff/mirror");
  const double ewj1 = r.Rate("gum_engine/evaluate_with_jacobian/env:0");
  const double cov1 = r.Rate("gum_engine/covariance_field/env:0/threads:1");
  const double cov_scalar = r.Rate("gum_engine/covariance_field_scalar/env:0/threads:1");
  const double cov2 = r.Rate("gum_engine/covariance_field/env:0/threads:2");
  const double cov_big1 = r.Rate("gum_engine/covariance_field/env:0/N:65536/threads:1");
  const double cov_big2 = r.Rate("gum_engine/covariance_field/env:0/N:65536/threads:2");
  const double field1 = r.Rate("gum_engine/field/env:0/threads:1");
  const double field2 = r.Rate("gum_engine/field/env:0/threads:2");
  const double points = r.Rate("gum_engine/points/env:0/budgets:0/threads:1");
  const double big1 = r.Rate("gum_engine/field/env:0/N:65536/threads:1");
  const double big2 = r.Rate("gum_engine/field/env:0/N:65536/threads:2");
  const double mcm1 = r.Rate("mcm/run/point/M:1000000/threads:1");
  const double mcm2 = r.Rate("mcm/run/point/M:1000000/threads:2");
  const double soa = r.Rate("gum/generated_nominal_soa/mirror/L:4");
  const double mcm_ceiling = r.Rate("mcm/ceiling/normals_and_forward");
  const double forward = r.Rate("forward/mirror");
  const double ginac = r.Rate("forward_ginac/mirror");

  Print(out,
        "\nvlt_bench summary (ratios from this run; mirror model, 20 error "
        "parameters + 3 readings)\n");
  Print(out, "GUM per point: value + 3x23 Jacobian + J U J^T\n");
  Line(out, "generated NominalJacobians, tight loop (ceiling)", nominal, "points");
  Line(out, "generated NominalJacobians, 4 SIMD lanes, tight loop", soa, "points");
  Line(out, "generated ForwardJacobians, tight loop", fj, "points");
  Line(out, "engine EvaluateWithJacobian (one point per call) + J U J^T", ewj1, "points");
  Line(out, "engine CovarianceField (4 SIMD lanes), 1 thread", cov1, "points");
  Line(out, "engine CovarianceField without the SIMD kernel, 1 thread", cov_scalar, "points");
  Line(out, "engine CovarianceField, 2 threads", cov2, "points");
  // The field computes the 3 variances of each point (what a map needs), not the full 3x3
  // covariance the other rows compute: not compared with them (issue 13: like for like).
  Line(out, "engine ExpandedUncertaintyField, 1 thread (3 variances only)", field1, "points");
  Line(out, "engine ExpandedUncertaintyField, 2 threads (3 variances only)", field2, "points");
  Line(out, "engine PropagatePoints (no budget), 1 thread", points, "points");
  Line(out, "Eigen AutoDiffScalar<Matrix<double,23,1>>", ad, "points");
  Line(out, "central finite differences (47 x Forward)", fd, "points");
  Print(out, "Monte Carlo, one point per trial\n");
  Line(out, "engine RunMcm, 1e6 trials, 1 thread", mcm1, "trials");
  Line(out, "engine RunMcm, 1e6 trials, 2 threads", mcm2, "trials");
  Line(out, "tight loop: 23 normals + Forward<double> (ceiling)", mcm_ceiling, "trials");
  Print(out, "Speed-up of the generated Jacobian (like for like: value + full 3x3 covariance)\n");
  Ratio(out, "tight loop vs autodiff", nominal, ad);
  Ratio(out, "tight loop vs finite differences", nominal, fd);
  Ratio(out, "engine CovarianceField vs autodiff", cov1, ad);
  Ratio(out, "engine CovarianceField vs finite differences", cov1, fd);
  Ratio(out, "engine CovarianceField, SIMD kernel vs scalar kernel", cov1, cov_scalar);
  Ratio(out, "generated Forward<double> vs GiNaC subs+evalf", forward, ginac);
  Ratio(out, "engine CovarianceField 4096 points, 2 threads / 1 thread", cov2, cov1);
  Ratio(out, "engine field 4096 points, 2 threads / 1 thread", field2, field1);
  Ratio(out, "engine field 65536 points, 2 threads / 1 thread", big2, big1);
  Ratio(out, "engine CovarianceField 65536 points, 2 threads / 1 thread", cov_big2, cov_big1);
  Print(out, "Targets\n");
  Target(out, "GUM engine (CovarianceField), 1 thread [M points/s]", cov1 / 1e6, 10.0);
  Target(out, "GUM tight loop (generated), 1 thread [M points/s]", nominal / 1e6, 10.0);
  Target(out, "GUM engine (CovarianceField) vs autodiff [x]", ad > 0 ? cov1 / ad : 0.0, 5.0);
  Target(out, "GUM engine (CovarianceField) vs finite differences [x]", fd > 0 ? cov1 / fd : 0.0, 20.0);
  Target(out, "MCM 1e6 trials, 1 thread [M trials/s]", mcm1 / 1e6, 5.0);
  Target(out, "MCM 1e6 trials, 2 threads / 1 thread [x]", mcm1 > 0 ? mcm2 / mcm1 : 0.0, 1.8);
  Target(out, "GUM CovarianceField 4096 points, 2 threads / 1 thread [x]", cov1 > 0 ? cov2 / cov1 : 0.0, 1.8);
  Target(out, "GUM field 4096 points, 2 threads / 1 thread [x]", field1 > 0 ? field2 / field1 : 0.0, 1.8);
  out.flush();
}

}  // namespace

int main(int argc, char** argv) {
  std::string format = "console";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const std::string key = "--benchmark_format=";
    if (arg.rfind(key, 0) == 0) format = arg.substr(key.size());
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  std::unique_ptr<benchmark::BenchmarkReporter> inner;
  if (format == "json") {
    inner = std::make_unique<benchmark::JSONReporter>();
  } else if (format != "console") {
    // csv (deprecated in Google Benchmark 1.7): the library's own reporter, no summary.
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  } else {
    inner = std::make_unique<benchmark::ConsoleReporter>(
        isatty(STDOUT_FILENO) ? benchmark::ConsoleReporter::OO_Color : benchmark::ConsoleReporter::OO_None);
  }
  SummaryReporter reporter(inner.get());
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::cout.flush();
  PrintSummary(reporter, format == "json" ? std::cerr : std::cout);
  benchmark::Shutdown();
  return 0;
}
