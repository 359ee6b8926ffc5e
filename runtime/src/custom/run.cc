// custom/run.cc — a custom-model job run (vlt/results.h RunCustomJob) and its files:
// outputs.csv, budget.csv, results.json ("vlt-custom-results/1"), report.html; docs/results.md
// "Custom-model jobs".
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "base/format.h"
#include "output/page.h"
#include "results/run_options.h"
#include "vlt/error.h"
#include "vlt/results.h"

namespace vlt {

namespace {

using json = nlohmann::ordered_json;

// JSON has no infinity: an infinite number of degrees of freedom is written as null.
json Dof(double nu) { return std::isfinite(nu) ? json(nu) : json(nullptr); }
std::string DofText(double nu) { return std::isfinite(nu) ? base_internal::Num(nu) : "inf"; }

}  // namespace

CustomResults RunCustomJob(const CustomJob& job, const RunOptions& options) {
  CustomResults r;
  r.vlt_version = VLT_VERSION;
  r.job_file = job.file;
  r.job_name = job.name;
  r.job_description = job.description;
  r.record = job.record;
  r.model = job.model;
  r.inputs = job.inputs;
  r.mcm_inputs = job.mcm_inputs;
  r.sources = job.sources;
  r.dof = job.dof;
  r.correlation = job.correlation;
  r.simultaneous = job.simultaneous;
  r.simultaneous_mcm_dof = job.simultaneous_mcm_dof;
  r.coverage_probability = job.monte_carlo.coverage_probability;
  r.n_dig = job.monte_carlo.n_dig;
  const ModelInfo& model = *job.model;

  // GUM (JCGM 100 5.1.2, 5.2.2; G.4 effective degrees of freedom; JCGM 102 6.3 for vectors).
  const auto gum_start = std::chrono::steady_clock::now();
  GumOptions gum_options;
  gum_options.coverage_probability = r.coverage_probability;
  InputDegreesOfFreedom dof{job.dof, job.simultaneous};
  try {
    r.gum = PropagateCustom(model, job.inputs, job.correlation, gum_options, dof);
  } catch (const NumericalError& e) {
    throw NumericalError(job.file + ": " + e.what());
  }
  r.gum_seconds = base_internal::Seconds(gum_start);
  r.outputs.resize(model.num_outputs);
  for (int o = 0; o < model.num_outputs; ++o) {
    r.outputs[o].gum = r.gum.outputs[o];
    r.outputs[o].tolerance = job.tolerances[o];
  }
  if (model.num_outputs >= 2) {
    r.region = CustomRegionResult{};
    r.region->gum_k = r.gum.region_k;
  }

  const bool run_mcm = options.monte_carlo && job.monte_carlo.enabled;
  if (run_mcm) {
    // JCGM 102 6.5.3: the multivariate t of N simultaneous inputs has nu = n - N and a covariance
    // only for nu > 2.
    for (std::size_t g = 0; g < job.simultaneous.size(); ++g) {
      if (job.simultaneous_mcm_dof[g] <= 2.0) {
        const int n = job.sources[job.simultaneous[g].front()].observations;
        throw InputError(
            job.file +
            ": observations: Monte Carlo needs at least N + 3 simultaneous observations of N "
            "inputs (JCGM 102 6.5.3: the multivariate t with nu = n - N <= 2 has no covariance); " +
            std::to_string(n) + " observations of " + std::to_string(job.simultaneous[g].size()) +
            " inputs: give more, or run with --no-mcm");
      }
    }
    // JCGM 101 6.4.9: a t distribution with nu <= 2 has no standard deviation.
    for (std::size_t i = 0; i < job.sources.size(); ++i) {
      bool grouped = false;
      for (const auto& set : job.simultaneous)
        grouped = grouped || std::find(set.begin(), set.end(), static_cast<int>(i)) != set.end();
      if (job.sources[i].kind == "type A" && !grouped && job.sources[i].observations < 4) {
        throw InputError(job.file + ": inputs." + job.inputs[i].name +
                         ".observations: Monte Carlo needs at least 4 observations of a Type A input "
                         "(JCGM 101 6.4.9: the t distribution with nu = n - 1 <= 2 has no standard "
                         "deviation); give more, or run with --no-mcm");
      }
    }
    McmSettings settings = results_internal::McmSettingsFor(
        job.monte_carlo, options, options.threads.value_or(job.monte_carlo.threads), job.file);
    for (int o = 0; o < model.num_outputs; ++o) {
      if (job.tolerances[o])
        settings.tolerances.push_back({o, job.tolerances[o]->lower, job.tolerances[o]->upper});
    }
    std::vector<MultivariateTGroup> t_groups;
    for (std::size_t g = 0; g < job.simultaneous.size(); ++g) {
      t_groups.push_back({job.simultaneous[g], job.simultaneous_mcm_dof[g]});
    }
    const auto mcm_start = std::chrono::steady_clock::now();
    McmResult mcm;
    try {
      mcm = RunMcmCustom(model, job.mcm_inputs, job.correlation, settings, t_groups);
    } catch (const NumericalError& e) {
      throw NumericalError(job.file + ": " + e.what());
    }
    r.mcm_seconds = base_internal::Seconds(mcm_start);
    r.has_mcm = true;
    std::vector<std::string> outcomes;
    for (int o = 0; o < model.num_outputs; ++o) {
      CustomOutputResult& out = r.outputs[o];
      out.has_mcm = true;
      out.mcm = mcm.outputs[o];
      // JCGM 101 8.2: the GUM interval y +- U (U = t_p(nu_eff) u) against the MCM symmetric one.
      out.validation =
          ValidateScalar(out.gum.name, out.gum.unit, out.gum.estimate, out.gum.u, out.gum.U,
                         out.mcm.symmetric, r.n_dig, mcm.trials, out.mcm.u, r.coverage_probability);
      CheckFiniteVariance(out.mcm, out.validation);
      outcomes.push_back(out.validation.outcome);
    }
    r.outcome = CombinedOutcome(outcomes);
    if (r.region && !mcm.vectors.empty()) {
      r.region->has_mcm = true;
      r.region->mcm = mcm.vectors.front();
      r.region->coverage_factor_ratio =
          r.region->mcm.has_region ? r.region->mcm.coverage_factor / r.region->gum_k : 0.0;
      const double norm = r.gum.covariance.norm();
      r.region->covariance_difference =
          norm > 0.0 ? (r.region->mcm.covariance - r.gum.covariance).norm() / norm : 0.0;
    }
    mcm.outputs.clear();
    mcm.vectors.clear();
    r.mcm = std::move(mcm);
  }
  for (CustomOutputResult& out : r.outputs) {
    if (!out.tolerance) continue;
    std::optional<double> p_mcm;
    if (out.has_mcm) p_mcm = out.mcm.conformity_probability;
    // The t of the truncated nu_eff, the same as U = t_p(nu_eff) u (JCGM 100 G.6.4).
    const double nu = std::isinf(out.gum.dof_effective)
                          ? out.gum.dof_effective
                          : std::max(1.0, std::floor(out.gum.dof_effective * (1.0 + 1e-9)));
    out.conformity = DecideConformity(*out.tolerance, out.gum.estimate, out.gum.u, out.gum.U, p_mcm, nu);
  }
  return r;
}

namespace {

using base_internal::Num;

std::string OutputsCsv(const CustomResults& r) {
  std::ostringstream out;
  out << "output,unit,estimate,u,dof_effective,k,U,gum_low,gum_high,u_with_second_order,second_order_ratio,"
         "gum_reliable,mcm_mean,mcm_u,mcm_symmetric_low,"
         "mcm_symmetric_high,mcm_shortest_low,mcm_shortest_high,validation,d_low,d_high,delta,"
         "tolerance_lower,tolerance_upper,conformity,probability_of_conformity_gum,"
         "probability_of_conformity_mcm\n";
  for (const CustomOutputResult& o : r.outputs) {
    const CustomOutput& g = o.gum;
    out << g.name << "," << g.unit << "," << Num(g.estimate) << "," << Num(g.u) << ","
        << DofText(g.dof_effective) << "," << Num(g.k) << "," << Num(g.U) << "," << Num(g.estimate - g.U)
        << "," << Num(g.estimate + g.U) << "," << Num(std::sqrt(g.u * g.u + g.second_order_variance)) << ","
        << (std::isfinite(g.second_order_ratio) ? Num(g.second_order_ratio) : std::string()) << ","
        << (g.gum_reliable ? "true" : "false") << ",";
    if (o.has_mcm) {
      out << Num(o.mcm.mean) << "," << Num(o.mcm.u) << "," << Num(o.mcm.symmetric.low) << ","
          << Num(o.mcm.symmetric.high) << "," << Num(o.mcm.shortest.low) << "," << Num(o.mcm.shortest.high)
          << "," << o.validation.outcome << "," << Num(o.validation.d_low) << "," << Num(o.validation.d_high)
          << "," << Num(o.validation.delta) << ",";
    } else {
      out << ",,,,,,not run,,,,";
    }
    if (o.conformity) {
      out << (std::isinf(o.tolerance->lower) ? "" : Num(o.tolerance->lower)) << ","
          << (std::isinf(o.tolerance->upper) ? "" : Num(o.tolerance->upper)) << "," << o.conformity->verdict
          << "," << Num(*o.conformity->probability_gum) << ","
          << (o.conformity->probability_mcm ? Num(*o.conformity->probability_mcm) : "");
    } else {
      out << ",,,,";
    }
    out << "\n";
  }
  return out.str();
}

std::string BudgetCsvText(const CustomResults& r) {
  std::ostringstream out;
  out << "output,output_unit,input,source,input_unit,estimate,u,dof,sensitivity,sensitivity_unit,"
         "contribution,variance,share\n";
  for (const CustomOutputResult& o : r.outputs) {
    for (const BudgetRow& row : o.gum.budget) {
      int i = -1;
      for (std::size_t k = 0; k < r.inputs.size(); ++k) {
        if (r.inputs[k].name == row.input) i = static_cast<int>(k);
      }
      out << o.gum.name << "," << o.gum.unit << "," << row.input << ",";
      if (i >= 0) {
        out << r.sources[i].kind << "," << row.input_unit << "," << Num(row.estimate) << "," << Num(row.u)
            << "," << DofText(r.dof[i]) << "," << Num(row.sensitivity(0)) << "," << row.sensitivity_unit
            << ",";
      } else {
        out << "correlation,,,,,,,";
      }
      out << Num(row.contribution(0)) << "," << Num(row.variance(0)) << "," << Num(row.share(0)) << "\n";
    }
  }
  return out.str();
}

// Index of the simultaneous-observation group input i belongs to, or -1.
int SimultaneousGroup(const CustomResults& r, int i) {
  for (std::size_t g = 0; g < r.simultaneous.size(); ++g) {
    if (std::find(r.simultaneous[g].begin(), r.simultaneous[g].end(), i) != r.simultaneous[g].end()) {
      return static_cast<int>(g);
    }
  }
  return -1;
}

// One input of results.json: its GUM and Monte Carlo descriptions and, for Type A, its observations.
json InputJson(const CustomResults& r, std::size_t i) {
  const UncertainInput& in = r.inputs[i];
  const CustomInputSource& src = r.sources[i];
  json e{{"name", in.name},
         {"unit", in.unit},
         {"source", src.kind},
         {"estimate", in.estimate},
         {"u", in.u},
         {"dof", Dof(r.dof[i])},
         {"distribution", in.distribution},
         {"shape", in.shape},
         {"monte_carlo",
          {{"distribution", r.mcm_inputs[i].distribution},
           {"standard_deviation", r.mcm_inputs[i].u},
           {"shape", r.mcm_inputs[i].shape}}}};
  const int group = SimultaneousGroup(r, static_cast<int>(i));
  if (group >= 0) {
    // JCGM 102 6.5.3: one multivariate t of the group; scale and nu = n - N.
    const double nu = r.simultaneous_mcm_dof[group], scale = r.mcm_inputs[i].u;
    e["monte_carlo"] = {
        {"distribution", "multivariate_t"},
        {"dof", nu},
        {"scale", scale},
        {"standard_deviation", nu > 2.0 ? json(scale * std::sqrt(nu / (nu - 2.0))) : json(nullptr)}};
  }
  if (src.kind == "type A") {
    e["observations"] = {
        {"n", src.observations}, {"standard_deviation", src.standard_deviation}, {"from", src.from}};
  }
  return e;
}

// One output of results.json: GUM (with the budget and the second-order check), Monte Carlo, the
// validation and the conformity decision.
json OutputJson(const CustomOutputResult& o) {
  const CustomOutput& g = o.gum;
  json budget = json::array();
  for (const BudgetRow& row : g.budget) {
    budget.push_back({{"input", row.input},
                      {"estimate", row.estimate},
                      {"u", row.u},
                      {"sensitivity", row.sensitivity(0)},
                      {"sensitivity_unit", row.sensitivity_unit},
                      {"contribution", row.contribution(0)},
                      {"variance", row.variance(0)},
                      {"share", row.share(0)}});
  }
  json e{{"name", g.name},
         {"unit", g.unit},
         {"gum",
          {{"estimate", g.estimate},
           {"u", g.u},
           {"dof_effective", Dof(g.dof_effective)},
           {"k", g.k},
           {"U", g.U},
           {"interval", {g.estimate - g.U, g.estimate + g.U}},
           {"second_order",
            {{"variance", g.second_order_variance},
             {"ratio", g.second_order_ratio},
             {"u_with_second_order", std::sqrt(g.u * g.u + g.second_order_variance)},
             {"threshold", kSecondOrderThreshold},
             {"gum_reliable", g.gum_reliable},
             {"decided", g.second_order_decided}}},
           {"budget", budget}}}};
  if (o.has_mcm) {
    e["mcm"] = {{"mean", o.mcm.mean},
                {"u", o.mcm.u},
                {"value_at_estimates", o.mcm.value_at_estimates},
                {"symmetric_interval", {o.mcm.symmetric.low, o.mcm.symmetric.high}},
                {"shortest_interval", {o.mcm.shortest.low, o.mcm.shortest.high}},
                {"numerical_tolerance", o.mcm.accuracy.delta},
                // vlt/mcm.h: null when not estimated or the tail is bounded (no finite number).
                {"tail_index", o.mcm.tail_index && std::isfinite(*o.mcm.tail_index) ? json(*o.mcm.tail_index)
                                                                                    : json(nullptr)},
                {"infinite_variance", o.mcm.infinite_variance}};
    e["validation"] = {{"outcome", o.validation.outcome},
                       {"d_low", o.validation.d_low},
                       {"d_high", o.validation.d_high},
                       {"delta", o.validation.delta},
                       {"mcm_tolerance", o.validation.mcm_tolerance},
                       {"trials_to_decide", o.validation.trials_to_decide > 0.0
                                                ? nlohmann::json(o.validation.trials_to_decide)
                                                : nlohmann::json(nullptr)},
                       {"verdict", o.validation.verdict}};
  }
  if (o.conformity) {
    e["conformity"] = {
        {"tolerance",
         {std::isinf(o.tolerance->lower) ? json(nullptr) : json(o.tolerance->lower),
          std::isinf(o.tolerance->upper) ? json(nullptr) : json(o.tolerance->upper)}},
        {"decision_rule", "ISO 14253-1:2017 guard band w = U"},
        {"verdict", o.conformity->verdict},
        {"guard_band", o.conformity->guard_band},
        {"probability_gum", *o.conformity->probability_gum},
        {"probability_mcm",
         o.conformity->probability_mcm ? json(*o.conformity->probability_mcm) : json(nullptr)}};
  }
  return e;
}

// The coverage region of all the outputs together (JCGM 102 7.7).
json CoverageRegionJson(const CustomResults& r) {
  const ModelInfo& model = *r.model;
  json reg{{"dimension", model.num_outputs}, {"gum_k", r.region->gum_k}};
  if (r.region->has_mcm) {
    json cov = json::array();
    for (Eigen::Index a = 0; a < r.region->mcm.covariance.rows(); ++a) {
      json row = json::array();
      for (Eigen::Index b = 0; b < r.region->mcm.covariance.cols(); ++b)
        row.push_back(r.region->mcm.covariance(a, b));
      cov.push_back(row);
    }
    reg["mcm_k"] =
        r.region->has_mcm && r.region->mcm.has_region ? json(r.region->mcm.coverage_factor) : json(nullptr);
    reg["mcm_covariance"] = cov;
    reg["coverage_factor_ratio"] =
        r.region->mcm.has_region ? json(r.region->coverage_factor_ratio) : json(nullptr);
    reg["covariance_difference"] = r.region->covariance_difference;
  }
  return reg;
}

json ResultsJsonObject(const CustomResults& r) {
  const ModelInfo& model = *r.model;
  json j;
  j["schema"] = "vlt-custom-results/1";
  j["vlt_version"] = r.vlt_version;
  j["job"] = {{"file", r.job_file},
              {"name", r.job_name},
              {"description", r.job_description},
              {"record", output_internal::RecordJson(r.record)}};
  j["model"] = {{"name", model.name},
                {"kind", model.kind},
                {"description", model.description},
                {"spec_file", model.spec_file}};
  j["coverage_probability"] = r.coverage_probability;
  json inputs = json::array();
  for (std::size_t i = 0; i < r.inputs.size(); ++i) inputs.push_back(InputJson(r, i));
  j["inputs"] = inputs;
  json corr = json::array();
  for (Eigen::Index a = 0; a < r.correlation.rows(); ++a) {
    for (Eigen::Index b = a + 1; b < r.correlation.cols(); ++b) {
      if (r.correlation(a, b) != 0.0) {
        corr.push_back({{"inputs", {r.inputs[a].name, r.inputs[b].name}}, {"r", r.correlation(a, b)}});
      }
    }
  }
  j["input_correlations"] = corr;
  json sim = json::array();
  for (const auto& set : r.simultaneous) {
    json names = json::array();
    for (int i : set) names.push_back(r.inputs[i].name);
    sim.push_back(names);
  }
  j["simultaneous_observations"] = sim;
  json outs = json::array();
  for (const CustomOutputResult& o : r.outputs) outs.push_back(OutputJson(o));
  j["outputs"] = outs;
  json gum_corr = json::array();
  for (Eigen::Index a = 0; a < r.gum.correlation.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < r.gum.correlation.cols(); ++b) row.push_back(r.gum.correlation(a, b));
    gum_corr.push_back(row);
  }
  j["output_correlation"] = gum_corr;
  if (r.region) j["coverage_region"] = CoverageRegionJson(r);
  if (!r.has_mcm) {
    j["monte_carlo"] = {{"enabled", false}};
  } else {
    j["monte_carlo"] = {{"enabled", true},
                        {"seed", r.mcm.seed},
                        {"trials", r.mcm.trials},
                        {"adaptive", r.mcm.adaptive},
                        {"converged", r.mcm.converged},
                        {"threads", r.mcm.threads},
                        {"ranks", r.mcm.ranks},
                        {"device", r.mcm.device},
                        {"device_note", r.mcm.device_note.empty() ? json(nullptr) : json(r.mcm.device_note)},
                        {"n_dig", r.n_dig},
                        {"interval_method", r.mcm.interval_method},
                        {"outcome", r.outcome}};
  }
  return j;
}

std::string Esc(const std::string& s) { return base_internal::HtmlEscape(s); }

// "k = 2.78" or "none" where the Monte Carlo region could not be formed.
std::string RegionK(const CustomRegionResult& region) {
  return region.mcm.has_region ? base_internal::Sig(region.mcm.coverage_factor, 4)
                               : std::string("none (singular covariance)");
}

std::string ReportHtmlText(const CustomResults& r) {
  const ModelInfo& model = *r.model;
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>vlt: " << Esc(r.job_name)
    << "</"
       "title>\n<style>body{font-family:sans-serif;margin:2em;max-width:72em}table{border-collapse:collapse;"
       "margin:1em 0}td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}th{background:#f3f3f3}"
       "td.l,th.l{text-align:left}.bar{background:#4a7fb5;height:.8em;display:inline-block}"
       ".bad{color:#b00;font-weight:bold}.ok{color:#070}</style></head><body>\n";
  h << "<h1>" << Esc(r.job_name) << "</h1>\n<p>" << Esc(r.job_description) << "</p>\n";
  if (!r.record.empty()) h << "<p>" << Esc(output_internal::RecordLine(r.record)) << "</p>\n";
  h << "<p>Model <b>" << Esc(model.name) << "</b> (" << Esc(model.spec_file)
    << "): " << Esc(model.description) << ". vlt " << Esc(r.vlt_version) << ", job file " << Esc(r.job_file)
    << ". Coverage probability " << Num(r.coverage_probability)
    << ". All values in the SI units shown.</p>\n";
  h << "<h2>Inputs</h2>\n<table><tr><th class=l>input</th><th class=l>source</th><th>estimate</th><th>u</th>"
       "<th class=l>unit</th><th>&nu;</th><th class=l>distribution (Monte Carlo)</th></tr>\n";
  for (std::size_t i = 0; i < r.inputs.size(); ++i) {
    const UncertainInput& in = r.inputs[i];
    std::string src = r.sources[i].kind;
    if (src == "type A")
      src += ": " + std::to_string(r.sources[i].observations) +
             " observations, s = " + base_internal::Sig(r.sources[i].standard_deviation, 4) + " (" +
             r.sources[i].from + ")";
    std::string dist = r.mcm_inputs[i].distribution;
    if (r.mcm_inputs[i].shape != 0.0) dist += " (" + base_internal::Sig(r.mcm_inputs[i].shape, 4) + ")";
    if (const int g = SimultaneousGroup(r, static_cast<int>(i)); g >= 0) {
      dist = "multivariate t (nu = " + base_internal::Sig(r.simultaneous_mcm_dof[g], 4) + ", scale " +
             base_internal::Sig(r.mcm_inputs[i].u, 4) + ")";
    }
    h << "<tr><td class=l>" << Esc(in.name) << "</td><td class=l>" << Esc(src) << "</td><td>"
      << Num(in.estimate) << "</td><td>" << base_internal::Sig(in.u, 4) << "</td><td class=l>" << Esc(in.unit)
      << "</td><td>" << DofText(r.dof[i]) << "</td><td class=l>" << Esc(dist) << "</td></tr>\n";
  }
  h << "</table>\n";
  bool any_corr = false;
  for (Eigen::Index a = 0; a < r.correlation.rows(); ++a) {
    for (Eigen::Index b = a + 1; b < r.correlation.cols(); ++b) {
      if (r.correlation(a, b) != 0.0) {
        if (!any_corr) h << "<p>Input correlations: ";
        h << (any_corr ? ", " : "") << "r(" << Esc(r.inputs[a].name) << ", " << Esc(r.inputs[b].name)
          << ") = " << base_internal::Sig(r.correlation(a, b), 4);
        any_corr = true;
      }
    }
  }
  if (any_corr) h << ".</p>\n";
  h << "<h2>Results</h2>\n<table><tr><th class=l>output</th><th class=l>unit</th><th>y (GUM)</th><th>u</th>"
       "<th>&nu;<sub>eff</sub></th><th>k</th><th>U</th><th>MCM mean</th><th>MCM u</th>"
       "<th>MCM symmetric interval</th><th>MCM shortest interval</th><th class=l>GUM vs MCM</th>"
       "<th class=l>linearisation (JCGM 100 5.1.2 note)</th></tr>\n";
  for (const CustomOutputResult& o : r.outputs) {
    const CustomOutput& g = o.gum;
    h << "<tr><td class=l>" << Esc(g.name) << "</td><td class=l>" << Esc(g.unit) << "</td><td>"
      << Num(g.estimate) << "</td><td>" << base_internal::Sig(g.u, 4) << "</td><td>"
      << DofText(std::floor(g.dof_effective * (1.0 + 1e-9))) << "</td><td>" << base_internal::Sig(g.k, 4)
      << "</td><td>" << base_internal::Sig(g.U, 4) << "</td>";
    if (o.has_mcm) {
      h << "<td>" << Num(o.mcm.mean) << "</td><td>" << base_internal::Sig(o.mcm.u, 4) << "</td><td>["
        << Num(o.mcm.symmetric.low) << ", " << Num(o.mcm.symmetric.high) << "]</td><td>["
        << Num(o.mcm.shortest.low) << ", " << Num(o.mcm.shortest.high) << "]</td><td class=\"l "
        << (o.validation.outcome == "validated" ? "ok" : "bad") << "\">" << Esc(o.validation.verdict)
        << "</td>";
    } else {
      h << "<td></td><td></td><td></td><td></td><td class=l>Monte Carlo not run</td>";
    }
    h << "<td class=\"l " << (g.gum_reliable ? "ok" : "bad") << "\">"
      << (g.gum_reliable ? "reliable" : "GUM NOT RELIABLE")
      << (g.second_order_decided
              ? ""
              : " (the second order cannot decide: the curvature changes within 1 u; use Monte Carlo)")
      << ": second-order terms at the estimates "
      << (std::isfinite(g.second_order_ratio)
              ? base_internal::Sig(100.0 * g.second_order_ratio, 3) + " % of u&sup2;"
              : std::string("where the first-order u is 0"))
      << ", u with them " << base_internal::Sig(std::sqrt(g.u * g.u + g.second_order_variance), 4) << "</td>";
    h << "</tr>\n";
  }
  h << "</table>\n";
  if (r.region) {
    h << "<p>Output vector (JCGM 102): GUM coverage region k = " << base_internal::Sig(r.region->gum_k, 4)
      << " (sqrt of the chi-square quantile, " << model.num_outputs << " dimensions)";
    if (r.region->has_mcm) {
      h << "; Monte Carlo k = " << RegionK(*r.region) << " (ratio "
        << (r.region->mcm.has_region ? base_internal::Sig(r.region->coverage_factor_ratio, 4)
                                     : std::string("-"))
        << "), relative covariance difference " << base_internal::Sig(r.region->covariance_difference, 3);
    }
    h << ". Output correlation (GUM): ";
    for (int a = 0; a < model.num_outputs; ++a) {
      for (int b = a + 1; b < model.num_outputs; ++b) {
        h << "r(" << Esc(model.outputs[a].name) << ", " << Esc(model.outputs[b].name)
          << ") = " << base_internal::Sig(r.gum.correlation(a, b), 4) << " ";
      }
    }
    h << "</p>\n";
  }
  bool any_tol = false;
  for (const CustomOutputResult& o : r.outputs) any_tol = any_tol || o.conformity.has_value();
  if (any_tol) {
    h << "<h2>Conformity (ISO 14253-1:2017, JCGM 106:2012)</h2>\n<table><tr><th class=l>output</th>"
         "<th class=l>tolerance</th><th>guard band U</th><th class=l>decision</th><th>p<sub>c</sub> "
         "(GUM)</th>"
         "<th>p<sub>c</sub> (Monte Carlo)</th></tr>\n";
    for (const CustomOutputResult& o : r.outputs) {
      if (!o.conformity) continue;
      h << "<tr><td class=l>" << Esc(o.gum.name) << "</td><td class=l>"
        << Esc(DescribeTolerance(*o.tolerance, o.gum.unit)) << "</td><td>"
        << base_internal::Sig(o.conformity->guard_band, 4) << "</td><td class=l>"
        << Esc(o.conformity->verdict) << "</td><td>" << base_internal::Sig(*o.conformity->probability_gum, 4)
        << "</td><td>"
        << (o.conformity->probability_mcm ? base_internal::Sig(*o.conformity->probability_mcm, 4)
                                          : std::string(""))
        << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  h << "<h2>Uncertainty budgets</h2>\n";
  for (const CustomOutputResult& o : r.outputs) {
    h << "<h3>" << Esc(o.gum.name) << " [" << Esc(o.gum.unit)
      << "]</h3>\n<table><tr><th class=l>input</th>"
         "<th>u(x)</th><th>c = &part;y/&part;x</th><th class=l>unit of c</th><th>c u</th><th>share of "
         "u&sup2;</th>"
         "<th class=l></th></tr>\n";
    for (const BudgetRow& row : o.gum.budget) {
      const double share = row.share(0);
      h << "<tr><td class=l>" << Esc(row.input) << "</td><td>" << base_internal::Sig(row.u, 4) << "</td><td>"
        << base_internal::Sig(row.sensitivity(0), 4) << "</td><td class=l>" << Esc(row.sensitivity_unit)
        << "</td><td>" << base_internal::Sig(row.contribution(0), 4) << "</td><td>"
        << base_internal::Sig(100.0 * share, 3) << " %</td><td class=l><span class=bar style=\"width:"
        << Num(std::round(std::max(0.0, share) * 200.0)) << "px\"></span></td></tr>\n";
    }
    h << "</table>\n";
  }
  if (r.has_mcm) {
    h << "<p>Monte Carlo (JCGM 101): " << r.mcm.trials << " trials"
      << (r.mcm.adaptive ? " (adaptive, 7.9.4)" : "") << ", seed " << r.mcm.seed << ", "
      << Esc(r.mcm.interval_method) << ".</p>\n";
  }
  h << "<script type=\"application/json\" id=\"results\">";
  h << base_internal::ScriptSafe(ResultsJsonObject(r).dump()) << "</script>\n</body></html>\n";
  return h.str();
}

}  // namespace

std::vector<std::pair<std::string, std::string>> ResultFiles(const CustomResults& r) {
  return {{"outputs.csv", OutputsCsv(r)},
          {"budget.csv", BudgetCsvText(r)},
          {"results.json", ResultsJsonObject(r).dump(1) + "\n"},
          {"report.html", ReportHtmlText(r)}};
}

std::string SummaryText(const CustomResults& r) {
  std::ostringstream out;
  char line[512];
  out << "vlt " << r.vlt_version << " — job '" << r.job_name << "' (" << r.job_file << "), custom model "
      << r.model->name << ", " << r.inputs.size() << " inputs, " << r.outputs.size() << " outputs\n";
  out << output_internal::RecordLine(r.record);
  std::snprintf(line, sizeof line, "Coverage probability %.6g: U = k u, k = t_p(nu_eff) (JCGM 100 G.4)\n\n",
                r.coverage_probability);
  out << line;
  std::snprintf(line, sizeof line, "%-16s %-6s %17s %11s %7s %6s %11s %11s  %s\n", "output", "unit", "y", "u",
                "nu_eff", "k", "U", "MCM u", "GUM vs MCM");
  out << line;
  for (const CustomOutputResult& o : r.outputs) {
    const CustomOutput& g = o.gum;
    std::string verdict = !o.has_mcm                                ? "not run"
                          : o.validation.outcome == "not validated" ? "NOT validated"
                                                                    : o.validation.outcome;
    if (!g.gum_reliable) {
      // JCGM 100 5.1.2 note, computed without Monte Carlo: said with --no-mcm too.
      char flag[128];
      if (!g.second_order_decided) {
        // The curvature changes within one u: no ratio says by how much (docs/gum.md).
        std::snprintf(flag, sizeof flag,
                      "GUM NOT RELIABLE (2nd order cannot decide: curvature changes within 1 u; "
                      "Monte Carlo); ");
      } else if (std::isfinite(g.second_order_ratio)) {
        std::snprintf(flag, sizeof flag, "GUM NOT RELIABLE (2nd order %.3g x u^2); ", g.second_order_ratio);
      } else {
        std::snprintf(flag, sizeof flag, "GUM NOT RELIABLE (first-order u is 0, 2nd order is not); ");
      }
      verdict = flag + verdict;
    }
    std::snprintf(line, sizeof line, "%-16s %-6s %17.10g %11.4g %7s %6.3f %11.4g %11s  %s\n", g.name.c_str(),
                  g.unit.c_str(), g.estimate, g.u,
                  DofText(std::floor(g.dof_effective * (1.0 + 1e-9))).c_str(), g.k, g.U,
                  !o.has_mcm                ? ""
                  : o.mcm.infinite_variance ? "none"
                                            : base_internal::Sig(o.mcm.u, 4).c_str(),
                  verdict.c_str());
    out << line;
  }
  bool without_variance = false;
  for (const CustomOutputResult& o : r.outputs) {
    if (!o.has_mcm || !o.mcm.infinite_variance) continue;
    without_variance = true;
    std::snprintf(
        line, sizeof line,
        "%s: the Monte Carlo values have no finite variance (tail index %.2f < 2, Hill's estimator): "
        "u does not exist (below 1 neither does the mean); the coverage interval [%.6g, %.6g] %s "
        "is the answer\n",
        o.gum.name.c_str(), o.mcm.tail_index.value_or(0.0), o.mcm.symmetric.low, o.mcm.symmetric.high,
        o.gum.unit.c_str());
    out << line;
  }
  if (r.region) {
    std::snprintf(line, sizeof line, "Output vector: GUM coverage region k = %.4f", r.region->gum_k);
    out << line;
    if (r.region->has_mcm) {
      // Without a variance there is no covariance, so no region built on one.
      out << ", Monte Carlo k = "
          << (without_variance ? std::string("none (no finite covariance)") : RegionK(*r.region));
    }
    out << "\n";
  }
  for (const CustomOutputResult& o : r.outputs) {
    if (!o.conformity) continue;
    std::snprintf(line, sizeof line, "%s %s: %s (guard band U = %.4g %s; probability of conformity %.4g GUM",
                  o.gum.name.c_str(), DescribeTolerance(*o.tolerance, o.gum.unit).c_str(),
                  o.conformity->verdict.c_str(), o.conformity->guard_band, o.gum.unit.c_str(),
                  *o.conformity->probability_gum);
    out << line;
    if (o.conformity->probability_mcm) {
      std::snprintf(line, sizeof line, ", %.4g Monte Carlo", *o.conformity->probability_mcm);
      out << line;
    }
    out << ")\n";
  }
  return out.str();
}

}  // namespace vlt
