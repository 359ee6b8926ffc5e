// vlt/custom_job.h — a job on a custom model (docs/custom-models.md): any measurement model
// Y = f(X) compiled by vlt-gen from a spec in models/ (kind = "custom"), its inputs overridden by
// the job (Type B: estimate, u, distribution, degrees of freedom; Type A: repeated observations),
// correlations between any inputs, and tolerances of the outputs for a conformity decision.
//
// A job file is a custom-model job when it has a [model] table (a tracker job has [tracker]);
// `vlt run` tells them apart with IsCustomModelJob.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "vlt/conformity.h"
#include "vlt/job.h"
#include "vlt/job_record.h"
#include "vlt/measurement_model.h"
#include "vlt/model_info.h"

namespace vlt {

// Where an input's value came from.
struct CustomInputSource {
  // "model" (the spec's values), "type B" (the job's values), "type A" (observations).
  std::string kind = "model";
  // Type A (JCGM 100 4.2): n observations q_k, mean q = sum q_k / n (4.2.1), experimental
  // standard deviation s(q_k) (4.2.2), u = s(q_k) / sqrt(n) (4.2.3), nu = n - 1 (G.3.3).
  int observations = 0;
  double standard_deviation = 0.0;  // s(q_k), the input's unit
  std::string from;                 // "job.toml: inputs.V.observations" or "data.csv: column V"
};

struct CustomJob {
  std::string file;
  std::filesystem::path base_dir;
  std::string name;
  std::string description;
  JobRecord record;                  // [job] customer, operator, ... (vlt/job_record.h)
  const ModelInfo* model = nullptr;  // kind "custom"
  // One per model input, spec order. For the GUM: estimate and standard uncertainty u. For Monte
  // Carlo the same, except Type A inputs (mcm_inputs below).
  std::vector<UncertainInput> inputs;
  // What the Monte Carlo method samples (JCGM 101 6.4.9 / JCGM 102 6.5.3): a Type A input on its
  // own is a scaled and shifted t with nu = n - 1, scale u (its standard deviation is
  // u sqrt(nu / (nu - 2)), so n >= 4); N simultaneous Type A inputs are normal with u = their
  // scale u sqrt((n - 1) / (n - N)), drawn as one multivariate t with nu = n - N
  // (simultaneous_mcm_dof; a covariance exists for n >= N + 3).
  std::vector<UncertainInput> mcm_inputs;
  std::vector<CustomInputSource> sources;
  std::vector<double> dof;      // nu per input (infinity: known exactly, JCGM 100 G.4.2)
  Eigen::MatrixXd correlation;  // inputs x inputs; identity when none given
  // Inputs of the same simultaneous observations (JCGM 100 5.2.3, H.2): their correlation is
  // the sample one (C.3.6 / eq. 17), one Welch-Satterthwaite component, one multivariate t.
  std::vector<std::vector<int>> simultaneous;
  std::vector<double> simultaneous_mcm_dof;          // nu = n - N of each group's multivariate t
  std::vector<std::optional<Tolerance>> tolerances;  // per output
  MonteCarloSettings monte_carlo;
  OutputSettings output;
  std::vector<std::string> warnings;
};

// True when the TOML text has a top-level [model] table (a custom-model job). Syntax errors are
// left to the parser that follows.
bool IsCustomModelJob(std::string_view text);
// The same for the job file at `path`; InputError "<path>: cannot read the job file".
bool IsCustomModelJobFile(const std::string& path);

// Reads and checks a custom-model job (one-line InputError "<file>: <key>: <problem>").
CustomJob ParseCustomJob(std::string_view text, const std::string& file,
                         const std::filesystem::path& base_dir);
CustomJob LoadCustomJob(const std::string& path);

}  // namespace vlt
