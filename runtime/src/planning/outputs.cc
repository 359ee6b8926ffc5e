// planning/outputs.cc — the files of `vlt plan` (vlt/planning.h, docs/planning.md): plan.json
// ("schema": "vlt-plan/1"), station_map.csv, station_map.html, planned_job.toml, and the
// terminal summary.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "base/format.h"
#include "base/section.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/planning.h"

namespace vlt {
namespace {

using json = nlohmann::ordered_json;

constexpr double kUm = 1e6;

json Position(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json Evaluation(const StationPlan& plan, const StationEvaluation& e) {
  json j;
  j["station"] = Position(e.station);
  j["feasible"] = e.feasible;
  if (e.feasible) {
    j["objective"] = e.objective;
    json terms = json::array();
    for (std::size_t i = 0; i < e.terms.size(); ++i) {
      const ObjectiveTerm& t = plan.settings.objective[i];
      terms.push_back({{"quantity", t.quantity}, {"weight", t.weight}, {"U", e.terms[i]}});
    }
    j["terms"] = terms;
    j["reason"] = nullptr;
  } else {
    j["objective"] = nullptr;
    j["terms"] = nullptr;
    j["reason"] = e.reason;
  }
  return j;
}

std::string PlanJson(const StationPlan& plan) {
  const OptimizeSettings& o = plan.settings;
  json j;
  j["schema"] = "vlt-plan/1";
  j["vlt_version"] = VLT_VERSION;
  j["job_file"] = plan.job->file;
  j["job_name"] = plan.job->name;
  j["model"] = plan.job->setup.model ? plan.job->setup.model->name : "";
  j["units"] = "SI: m, rad; objective and U in m";
  json region;
  json floor = json::array();
  for (const Eigen::Vector2d& p : o.floor) floor.push_back({p.x(), p.y()});
  region["floor"] = floor;
  region["height"] = {o.z_min, o.z_max};
  region["min_range"] = o.min_range;
  region["max_range"] = o.max_range;
  region["acceptance_angle"] = o.acceptance_angle > 0.0 ? json(o.acceptance_angle) : json(nullptr);
  json keep_out = json::array();
  for (const KeepOutBox& b : o.keep_out)
    keep_out.push_back({{"name", b.name}, {"min", Position(b.min)}, {"max", Position(b.max)}});
  region["keep_out"] = keep_out;
  j["region"] = region;
  json terms = json::array();
  for (const ObjectiveTerm& t : o.objective) {
    terms.push_back({{"quantity", t.quantity},
                     {"weight", t.weight},
                     {"definition", t.task < 0 ? "largest |U| = sqrt(U_x^2 + U_y^2 + U_z^2) of the points"
                                               : "expanded uncertainty U = k u of the task quantity"}});
  }
  j["objective"] = {{"definition", "sum of weight * term, m"},
                    {"coverage_probability", plan.map.coverage_probability},
                    {"k", plan.map.k},
                    {"terms", terms}};
  j["recommended"] = Evaluation(plan, plan.recommended);
  j["job_station"] = Evaluation(plan, plan.job_station);
  j["search"] = {{"global", plan.global_algorithm},
                 {"local", plan.local_algorithm},
                 {"nlopt_version", plan.nlopt_version},
                 {"seed", o.seed},
                 {"evaluations",
                  {{"global", plan.global_evaluations},
                   {"local", plan.local_evaluations},
                   {"map", plan.map_evaluations}}},
                 {"seconds", plan.seconds}};
  j["map"] = nlohmann::ordered_json::parse(MapJson(plan.map, -1));
  return j.dump(1);
}

std::string StationMapCsv(const MapResult& map) {
  std::string out = "x_m,y_m,z_m,objective_um,status\n";
  std::size_t skipped = 0;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      base_internal::AppendNum(out, map.nodes[i][k]);
      out += ',';
    }
    if (map.computed[i]) {
      base_internal::AppendNum(out, map.U_norm[i] * kUm);
      out += ",ok\n";
    } else {
      std::string reason = skipped < map.skipped.size() ? map.skipped[skipped] : "infeasible";
      ++skipped;
      const std::size_t colon = reason.find("m: ");
      if (colon != std::string::npos) reason = reason.substr(colon + 3);
      std::string field = "infeasible: " + reason;
      if (field.find_first_of(",\"") != std::string::npos) {
        std::string quoted = "\"";
        for (char c : field) {
          if (c == '"') quoted += '"';
          quoted += c;
        }
        field = quoted + "\"";
      }
      out += "," + field + "\n";
    }
  }
  return out;
}

// The job file with [station] tx, ty, tz at the recommendation (1 um), relative file names made
// absolute (the planned job is written elsewhere). toml++ rewrites the document: comments of the
// original are not kept.
std::string PlannedJob(const StationPlan& plan) {
  const Job& job = *plan.job;
  const std::string text = ReadInputFile(job.file, job.file, "cannot read the job file again to write the planned job");
  toml::table doc;
  try {
    doc = base_internal::ParseToml(text, job.file);
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (the job file changed while planning)");
  }
  auto absolute = [&](const char* section, const char* key) {
    toml::table* t = doc[section].as_table();
    if (!t) return;
    toml::node* n = t->get(key);
    if (!n || !n->is_string()) return;
    std::filesystem::path p(*n->value<std::string>());
    if (p.is_relative())
      t->insert_or_assign(key, std::filesystem::absolute(job.base_dir / p).lexically_normal().string());
  };
  absolute("plan", "csv");
  absolute("nominal", "csv");
  absolute("tracker", "calibration");
  absolute("output", "directory");
  if (!doc["station"].as_table()) doc.insert_or_assign("station", toml::table{});
  toml::table& station = *doc["station"].as_table();
  const char* keys[3] = {"tx", "ty", "tz"};
  // The station that was judged, to the bit (shortest round-trip digits: "1.234567 m" for a
  // station on the 1 um grid; all 17 digits for the unrounded optimum kept when rounding made it
  // infeasible): `vlt run planned_job.toml` then reproduces the plan exactly.
  for (int k = 0; k < 3; ++k) {
    const std::string value = base_internal::Num(plan.recommended.station[k]) + " m";
    if (toml::table* t = station[keys[k]].as_table()) {
      t->insert_or_assign("estimate", value);
    } else {
      station.insert_or_assign(keys[k], value);
    }
  }
  std::ostringstream out;
  out << "# Written by vlt " << VLT_VERSION << " plan from " << job.file
      << ": [station] tx, ty, tz at the recommended\n"
      << "# station (objective " << plan.recommended.objective * kUm
      << " µm); everything else as in that job.\n"
      << "# Comments of the original are not kept.\n\n"
      << doc << "\n";
  return out.str();
}

}  // namespace

std::vector<std::pair<std::string, std::string>> PlanFiles(const StationPlan& plan) {
  const std::string title = plan.job->name + ": objective over the station positions";
  return {{"plan.json", PlanJson(plan)},
          {"station_map.csv", StationMapCsv(plan.map)},
          {"station_map.html", MapHtml(plan.map, title)},
          {"planned_job.toml", PlannedJob(plan)}};
}

std::string PlanSummary(const StationPlan& plan) {
  std::ostringstream s;
  char line[512];
  s << "Station plan for job '" << plan.job->name << "' (model "
    << (plan.job->setup.model ? plan.job->setup.model->name : "") << "): " << plan.map.quantity << "\n";
  auto show = [&](const char* label, const StationEvaluation& e) {
    std::snprintf(line, sizeof line, "  %-14s x = %.6f m, y = %.6f m, z = %.6f m: ", label, e.station.x(),
                  e.station.y(), e.station.z());
    s << line;
    if (e.feasible) {
      std::snprintf(line, sizeof line, "objective %.4g µm", e.objective * kUm);
      s << line;
      if (e.terms.size() > 1) {
        s << " (";
        for (std::size_t i = 0; i < e.terms.size(); ++i) {
          std::snprintf(line, sizeof line, "%s%s %.4g µm", i ? ", " : "",
                        plan.settings.objective[i].quantity.c_str(), e.terms[i] * kUm);
          s << line;
        }
        s << ")";
      }
      s << "\n";
    } else {
      s << "not feasible: " << e.reason << "\n";
    }
  };
  show("recommended", plan.recommended);
  show("job's station", plan.job_station);
  std::snprintf(line, sizeof line,
                "Searched %lld positions (%s, seed %llu) + %lld (%s) + %lld map nodes in %.2f s; %zu node(s) "
                "infeasible\n",
                static_cast<long long>(plan.global_evaluations), plan.global_algorithm.c_str(),
                static_cast<unsigned long long>(plan.settings.seed),
                static_cast<long long>(plan.local_evaluations), plan.local_algorithm.c_str(),
                static_cast<long long>(plan.map_evaluations), plan.seconds, plan.map.skipped.size());
  s << line;
  return s.str();
}

}  // namespace vlt
