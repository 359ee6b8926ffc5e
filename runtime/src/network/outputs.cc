// network/outputs.cc — the files of `vlt network` (outputs.h). CSVs and results.json are SI with
// the unit in every column name; the summary prints um and arcsec and says so.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <cctype>
#include <set>
#include <numbers>

#include <filesystem>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "output/page.h"
#include "vlt/network.h"
#include "base/format.h"
#include "vlt/calibration.h"
#include "vlt/results.h"

namespace vlt::network_outputs {

using output_internal::ScriptJson;

namespace {

using base_internal::AppendNum;
using base_internal::Fixed;
using base_internal::HtmlEscape;
using base_internal::Num;
std::string Csv(const std::string& s) { return base_internal::CsvField(s); }

constexpr double kArcsec = std::numbers::pi / (180.0 * 3600.0);

// "AT1 (head), AT2 (mirror)".
std::string InstrumentList(const Network& network) {
  std::string out;
  for (const NetworkInstrument& in : network.instruments) {
    if (!out.empty()) out += ", ";
    out += in.name;
    out += " (";
    out += in.setup.model->name;
    out += ")";
  }
  return out;
}

// The adjustment at a glance: mode, instruments, redundancy, chi-square, variance shares, and the
// Monte Carlo check where it ran.
void AdjustmentSection(std::ostringstream& body, const NetworkJob& job, const NetworkResult& result,
                       const NetworkMonteCarlo* mc) {
  body << "<section><h2>Adjustment</h2><table>"
       << "<tr><th class=\"l\">mode</th><td class=\"l\">"
       << (job.offline ? "plan (predicted uncertainties of planned readings)" : "measured readings")
       << "</td></tr>"
       << "<tr><th class=\"l\">instruments (model)</th><td class=\"l\">"
       << HtmlEscape(InstrumentList(job.network)) << "</td></tr>"
       << "<tr><th class=\"l\">stations / targets</th><td class=\"l\">" << result.stations.size() << " / "
       << result.targets.size() << "</td></tr>"
       << "<tr><th class=\"l\">observations / unknowns / dof</th><td class=\"l\">" << result.observations
       << " / " << result.unknowns << " / " << result.dof << "</td></tr>"
       << "<tr><th class=\"l\">chi-square, Birge ratio, p</th><td class=\"l\">"
       << base_internal::Sig(result.chi2, 4) << ", " << Fixed(result.birge_ratio, 3) << ", "
       << Fixed(result.p_value, 3) << "</td></tr>"
       << "<tr><th class=\"l\">chi-square, p with the instruments' and the air's stated errors as random "
          "effects (the fit test's, N-8)</th><td class=\"l\">"
       << base_internal::Sig(result.chi2_random_effects, 4) << ", " << Fixed(result.p_value_random_effects, 3)
       << "</td></tr>"
       << "<tr><th class=\"l\">outliers (|w| &gt; " << Fixed(job.network.outlier_limit, 2)
       << ")</th><td class=\"l\">" << result.outliers << "</td></tr>"
       << "<tr><th class=\"l\">self-calibrated inputs</th><td class=\"l\">" << result.parameters.size()
       << "</td></tr>"
       << "<tr><th class=\"l\">targets' variance from reading noise and references / from the instruments' "
          "parameters</th><td class=\"l\">"
       << Fixed(100.0 * result.share_noise, 1) << " % / " << Fixed(100.0 * result.share_consider, 1)
       << " %</td></tr>"
       << "<tr><th class=\"l\">coverage factor k (p = " << Num(job.network.coverage_probability)
       << ", normal)</th><td class=\"l\">" << Fixed(result.k, 3) << "</td></tr>";
  if (mc) {
    body << "<tr><th class=\"l\">Monte Carlo (" << mc->trials
         << " re-adjustments): u_MCM / u_GUM farthest from 1</th><td class=\"l "
         << (mc->agrees ? "ok" : "bad") << "\">" << Fixed(mc->worst_ratio, 3) << " at "
         << HtmlEscape(mc->worst) << " (tolerance &plusmn; " << Fixed(mc->tolerance, 3)
         << "): " << (mc->agrees ? "the GUM agrees" : "the GUM does not agree") << "</td></tr>";
  }
  body << "</table></section>\n";
}

// The x, y, z arrays of one Plotly 3-D trace; a null point breaks a line.
struct Trace3d {
  nlohmann::json x = nlohmann::json::array(), y = nlohmann::json::array(), z = nlohmann::json::array();
  void Add(const Eigen::Vector3d& p) {
    x.push_back(p(0));
    y.push_back(p(1));
    z.push_back(p(2));
  }
  void Break() {
    x.push_back(nullptr);
    y.push_back(nullptr);
    z.push_back(nullptr);
  }
  std::string Xyz() const { return "x:" + ScriptJson(x) + ",y:" + ScriptJson(y) + ",z:" + ScriptJson(z); }
};

// Enlargement of the coverage ellipsoids: the largest axis drawn at 4 % of the network's extent.
double EllipsoidScale(const NetworkResult& result) {
  double extent = 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  for (const AdjustedTarget& t : result.targets) {
    lo = lo.cwiseMin(t.position);
    hi = hi.cwiseMax(t.position);
  }
  for (const AdjustedStation& st : result.stations) {
    lo = lo.cwiseMin(st.pose.tail<3>());
    hi = hi.cwiseMax(st.pose.tail<3>());
  }
  extent = (hi - lo).norm();
  double largest_axis = 0.0;
  for (const AdjustedTarget& t : result.targets) {
    largest_axis = std::max(
        largest_axis,
        result.k *
            std::sqrt(std::max(
                0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(t.covariance).eigenvalues().maxCoeff())));
  }
  const double scale = largest_axis > 0.0 ? 0.04 * extent / largest_axis : 1.0;
  // A factor one can read off a printed figure: 1, 2 or 5 times a power of ten, at most the scale
  // that makes the largest axis 4 % of the network (18118.388 drawn as 10000; issue 34).
  const double decade = std::pow(10.0, std::floor(std::log10(scale)));
  for (const double step : {5.0, 2.0, 1.0}) {
    if (step * decade <= scale) return step * decade;
  }
  return decade;
}

// One line from each station to every target it reads.
Trace3d LinesOfSight(const NetworkJob& job, const NetworkResult& result) {
  Trace3d lines;
  std::map<std::string, int> target_of;
  for (std::size_t t = 0; t < result.targets.size(); ++t)
    target_of[result.targets[t].name] = static_cast<int>(t);
  for (std::size_t i = 0; i < job.network.stations.size(); ++i) {
    std::set<std::string> seen;
    for (const TargetReading& r : job.network.stations[i].readings) {
      if (!seen.insert(r.target).second) continue;
      const Eigen::Vector3d& p = result.targets[target_of.at(r.target)].position;
      const Eigen::Vector3d o = result.stations[i].pose.tail<3>();
      lines.Add(o);
      lines.Add(p);
      lines.Break();
    }
  }
  return lines;
}

// The three principal axes of every target's coverage ellipsoid, `scale` times enlarged.
Trace3d EllipsoidAxes(const NetworkResult& result, double scale) {
  Trace3d axes;
  for (const AdjustedTarget& t : result.targets) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(t.covariance);
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d axis =
          eig.eigenvectors().col(c) * result.k * std::sqrt(std::max(0.0, eig.eigenvalues()(c))) * scale;
      for (const Eigen::Vector3d& p :
           {Eigen::Vector3d(t.position - axis), Eigen::Vector3d(t.position + axis)})
        axes.Add(p);
      axes.Break();
    }
  }
  return axes;
}

// The network in 3-D: stations, targets coloured by |U|, lines of sight, ellipsoid axes.
void NetworkView(std::ostringstream& body, std::ostringstream& script, const NetworkJob& job,
                 const NetworkResult& result) {
  const double scale = EllipsoidScale(result);
  body << "<section><h2>The network</h2><p class=\"note\">Part frame, m. Targets coloured by |U| = k "
          "sqrt(trace C) in µm; grey lines: lines of "
          "sight; the three principal axes of each target's coverage ellipsoid (k sqrt(eigenvalues)) drawn "
       << Num(scale) << " times enlarged.</p><div id=\"net\" class=\"plot\"></div></section>\n";
  Trace3d targets;
  nlohmann::json tc = nlohmann::json::array(), tn = nlohmann::json::array();
  for (const AdjustedTarget& t : result.targets) {
    targets.Add(t.position);
    tc.push_back(result.k * std::sqrt(t.covariance.trace()) * 1e6);
    tn.push_back(t.name);
  }
  Trace3d stations;
  nlohmann::json sn = nlohmann::json::array();
  for (const AdjustedStation& st : result.stations) {
    stations.Add(st.pose.tail<3>());
    sn.push_back(st.name + (st.datum ? " (datum)" : ""));
  }
  script << "Plotly.newPlot('net',["
         << "{type:'scatter3d',mode:'lines',name:'lines of "
            "sight',hoverinfo:'skip',line:{color:'rgba(120,120,120,0.35)',width:1},"
         << LinesOfSight(job, result).Xyz() << "},"
         << "{type:'scatter3d',mode:'lines',name:'coverage ellipsoid "
            "axes',hoverinfo:'skip',line:{color:'#b42318',width:3},"
         << EllipsoidAxes(result, scale).Xyz() << "},"
         << "{type:'scatter3d',mode:'markers',name:'targets',text:" << ScriptJson(tn) << "," << targets.Xyz()
         << ",marker:{size:4,color:" << ScriptJson(tc)
         << ",colorscale:'Viridis',colorbar:{title:'|U| / µm',x:1.02}},hovertemplate:'%{text}<br>|U| "
            "%{marker.color:.1f} µm<extra></extra>'},"
         << "{type:'scatter3d',mode:'markers+text',name:'stations',text:" << ScriptJson(sn) << ","
         << stations.Xyz() << ",marker:{size:7,symbol:'diamond',color:'#1f3a5f'}}"
         << "],{margin:{l:0,r:0,t:10,b:0},legend:{x:0,y:1},scene:{aspectmode:'data',xaxis:{title:'x / "
            "m'},yaxis:{title:'y / m'},zaxis:{title:'z / m'}}},{responsive:true}).then(done);";
}

void TargetsTable(std::ostringstream& body, const NetworkResult& result) {
  body << "<section><h2>Targets</h2><p class=\"note\">Part frame. U = k u per coordinate, µm; the full "
          "covariance (targets with each "
          "other and with the stations) is in covariance.csv.</p><table><tr><th class=\"l\">target</th><th>x "
          "/ m</th><th>y / m</th><th>z / m</th>"
          "<th>U<sub>x</sub> / µm</th><th>U<sub>y</sub> / µm</th><th>U<sub>z</sub> / "
          "µm</th><th>stations</th><th class=\"l\">reference</th></tr>";
  for (const AdjustedTarget& t : result.targets) {
    body << "<tr><td class=\"l\">" << HtmlEscape(t.name) << "</td>";
    for (int c = 0; c < 3; ++c) body << "<td>" << Fixed(t.position(c), 6) << "</td>";
    for (int c = 0; c < 3; ++c)
      body << "<td>" << Fixed(result.k * std::sqrt(t.covariance(c, c)) * 1e6, 1) << "</td>";
    body << "<td>" << t.stations << "</td><td class=\"l\">" << (t.reference ? "yes" : "") << "</td></tr>";
  }
  body << "</table></section>\n";
}

void StationsTable(std::ostringstream& body, const NetworkResult& result) {
  body << "<section><h2>Stations</h2><p class=\"note\">Pose: x_part = R x_station + t, R = Rz(rz) Ry(ry) "
          "Rx(rx); "
          "angles in degrees, their U in arcsec; t in m, its U in µm.</p><table><tr><th "
          "class=\"l\">station</th><th>rx / deg</th><th>ry / deg</th>"
          "<th>rz / deg</th><th>tx / m</th><th>ty / m</th><th>tz / m</th><th>U(rx, ry, rz) / "
          "arcsec</th><th>U(tx, ty, tz) / µm</th><th>readings</th></tr>";
  for (const AdjustedStation& st : result.stations) {
    body << "<tr><td class=\"l\">" << HtmlEscape(st.name) << (st.datum ? " (datum)" : "") << "</td>";
    for (int c = 0; c < 3; ++c) body << "<td>" << Fixed(st.pose(c) * 180.0 / std::numbers::pi, 6) << "</td>";
    for (int c = 3; c < 6; ++c) body << "<td>" << Fixed(st.pose(c), 6) << "</td>";
    body << "<td>";
    for (int c = 0; c < 3; ++c)
      body << (c ? ", " : "") << Fixed(result.k * std::sqrt(st.covariance(c, c)) / kArcsec, 2);
    body << "</td><td>";
    for (int c = 3; c < 6; ++c)
      body << (c > 3 ? ", " : "") << Fixed(result.k * std::sqrt(st.covariance(c, c)) * 1e6, 1);
    body << "</td><td>" << st.readings << "</td></tr>";
  }
  body << "</table></section>\n";
}

// One row of the air table: a station's air from `elapsed_h` on ("start" for its first).
void AirRow(std::ostringstream& body, const std::string& station, const std::string& from,
            const Environment& air, const std::string& sensor) {
  body << "<tr><td class=\"l\">" << HtmlEscape(station) << "</td><td>" << from << "</td><td>"
       << Fixed(air.temperature.estimate, 2) << "</td><td>" << Fixed(air.temperature.u, 2) << "</td><td>"
       << Fixed(air.pressure.estimate, 0) << "</td><td>" << Fixed(air.pressure.u, 0) << "</td><td>"
       << Fixed(air.humidity.estimate, 1) << "</td><td>" << Fixed(air.humidity.u, 1)
       << "</td><td class=\"l\">" << HtmlEscape(sensor.empty() ? "-" : sensor) << "</td></tr>";
}

// The air of the stations that have their own (N-2a), with the sensor that gave it; an air that
// changes during a station's readings one row per change, from the hours since the network's
// first reading.
void StationAirTable(std::ostringstream& body, const Network& network, double origin) {
  body << "<section><h2>Air per station</h2><p class=\"note\">Each of these stations' ranges are "
          "corrected with its own air (from the time given on, where it changes while the station "
          "reads); its u is propagated as the station's own inputs, correlated between airs that "
          "read one sensor through the sensor's u. Other stations take their instrument's air.</p>"
          "<table><tr><th class=\"l\">station</th><th>from / h</th><th>temperature / degC</th>"
          "<th>u / K</th><th>pressure / Pa</th><th>u / Pa</th><th>humidity / %</th><th>u / %</th>"
          "<th class=\"l\">sensor</th></tr>";
  for (const NetworkStation& st : network.stations) {
    if (!st.environment) continue;
    AirRow(body, st.name, "start", *st.environment, st.air_sensor);
    for (const NetworkAirChange& change : st.air_changes)
      AirRow(body, st.name, Fixed((change.from - origin) / 3600.0, 3), change.environment, change.sensor);
  }
  body << "</table></section>\n";
}

// The earliest time of the network's readings: the origin of the elapsed hours in drift.csv and the
// drift chart (N-12).
double TimeOrigin(const Network& network) {
  double origin = std::numeric_limits<double>::infinity();
  for (const NetworkStation& st : network.stations)
    for (const TargetReading& r : st.readings)
      if (r.time) origin = std::min(origin, *r.time);
  return std::isfinite(origin) ? origin : 0.0;
}

bool AnyDrift(const NetworkResult& result) {
  return std::any_of(result.stations.begin(), result.stations.end(),
                     [](const AdjustedStation& st) { return !st.drift.empty(); });
}

// |U| of a drift offset's translation: k sqrt(trace of its 3 x 3 block) [m].
double DriftTranslationU(const NetworkResult& result, const AdjustedDriftEpoch& epoch) {
  return result.k * std::sqrt(std::max(0.0, epoch.covariance.bottomRightCorner<3, 3>().trace()));
}

// Drift vs time (N-12): each drifting station's translation change since its first knot, per axis,
// with error bars U = k u, and the knots' table.
void DriftSection(std::ostringstream& body, std::ostringstream& script, const NetworkJob& job,
                  const NetworkResult& result) {
  const double origin = TimeOrigin(job.network);
  body
      << "<section><h2>Drift</h2><p class=\"note\">Each drifting station's pose change since its first "
         "reading (docs/network.md N-12: piecewise linear between its knots — first reading, drift checks, "
         "last reading — each segment's rate an unknown with the stated prior). Translation in µm with "
         "error bars U = k u (k = "
      << Fixed(result.k, 2)
      << "), hours from the network's first reading. The poses of every reading "
         "between two knots are interpolated, and their uncertainty is in every target.</p>"
         "<div id=\"drift\" class=\"plot\" style=\"height:420px\"></div><table><tr><th "
         "class=\"l\">station</th>"
         "<th>knot</th><th>time / h</th><th>&Delta;tx / µm</th><th>&Delta;ty / µm</th><th>&Delta;tz / µm</th>"
         "<th>U(&Delta;t) / µm</th><th>&Delta;rx / arcsec</th><th>&Delta;ry / arcsec</th><th>&Delta;rz / "
         "arcsec</th></tr>";
  std::ostringstream traces;
  static const char* kAxis[3] = {"x", "y", "z"};
  for (const AdjustedStation& st : result.stations) {
    if (st.drift.empty()) continue;
    for (std::size_t k = 0; k < st.drift.size(); ++k) {
      const AdjustedDriftEpoch& e = st.drift[k];
      body << "<tr><td class=\"l\">" << HtmlEscape(st.name) << "</td><td>" << k << "</td><td>"
           << Fixed((e.time - origin) / 3600.0, 3) << "</td>";
      for (int c = 3; c < 6; ++c) body << "<td>" << Fixed(e.offset(c) * 1e6, 1) << "</td>";
      body << "<td>" << Fixed(DriftTranslationU(result, e) * 1e6, 1) << "</td>";
      for (int c = 0; c < 3; ++c)
        body << "<td>" << Fixed(e.offset(c) / std::numbers::pi * 180.0 * 3600.0, 2) << "</td>";
      body << "</tr>";
    }
    for (int c = 0; c < 3; ++c) {
      nlohmann::json t = nlohmann::json::array(), v = nlohmann::json::array(), U = nlohmann::json::array();
      for (const AdjustedDriftEpoch& e : st.drift) {
        t.push_back((e.time - origin) / 3600.0);
        v.push_back(e.offset(3 + c) * 1e6);
        U.push_back(result.k * std::sqrt(std::max(0.0, e.covariance(3 + c, 3 + c))) * 1e6);
      }
      traces << "{type:'scatter',mode:'lines+markers',name:"
             << ScriptJson(nlohmann::json(st.name + " t" + kAxis[c])) << ",x:" << ScriptJson(t)
             << ",y:" << ScriptJson(v) << ",error_y:{type:'data',array:" << ScriptJson(U)
             << ",visible:true}},";
    }
  }
  body << "</table></section>\n";
  script << "Plotly.newPlot('drift',[" << traces.str()
         << "],{margin:{l:60,r:10,t:10,b:50},xaxis:{title:'time / h'},yaxis:{title:'drift / µm'}},"
            "{responsive:true}).then(done);";
}

// The length test (N-13): counts of the ISO 14253-1 verdicts and the length with the largest
// |E| / MPE, overall and per station.
struct LengthTestSummary {
  int conforms = 0, fails = 0, undetermined = 0;
  const NetworkLengthError* worst = nullptr;
  void Add(const NetworkLengthError& e) {
    if (e.decision.verdict == "conforms")
      ++conforms;
    else if (e.decision.verdict == "does not conform")
      ++fails;
    else
      ++undetermined;
    if (!worst || std::abs(e.error) / e.mpe > std::abs(worst->error) / worst->mpe) worst = &e;
  }
  int count() const { return conforms + fails + undetermined; }
  // The test's verdict: every length conforms; one that does not fails it; otherwise undetermined.
  std::string Verdict() const {
    return fails > 0 ? "does not conform" : undetermined > 0 ? "undetermined" : "conforms";
  }
};

void LengthTestSection(std::ostringstream& body, const NetworkJob& job,
                       const std::vector<NetworkLengthError>& errors) {
  const NetworkLengthTest& test = *job.length_test;
  body << "<section><h2>Length test from the network (ISO 10360-10)</h2><p class=\"note\">Each station's own "
          "length between two targets (its readings through the instrument as it stands) against the "
          "network's calibrated length (docs/network.md N-13; Wang, Muralikrishnan et al. 2020). E in µm; "
          "MPE = "
       << Fixed(test.mpe_a * 1e6, 1) << " µm + " << Fixed(test.mpe_b * 1e6, 2)
       << " µm/m; U the network length's expanded uncertainty, the guard band of the ISO 14253-1 "
          "decision. Lengths from "
       << Fixed(test.min_length, 2)
       << " m; every length in length_test.csv.</p><table><tr><th class=\"l\">station</th>"
          "<th>lengths</th><th>conform</th><th>do not conform</th><th>undetermined</th><th>largest |E| / "
          "MPE</th>"
          "<th class=\"l\">at</th><th>L / m</th><th>E / µm</th><th>U / µm</th><th "
          "class=\"l\">verdict</th></tr>";
  std::vector<std::string> order;
  std::map<std::string, LengthTestSummary> by_station;
  for (const NetworkLengthError& e : errors) {
    if (!by_station.count(e.station)) order.push_back(e.station);
    by_station[e.station].Add(e);
  }
  for (const std::string& name : order) {
    const LengthTestSummary& s = by_station[name];
    const NetworkLengthError& w = *s.worst;
    const std::string verdict = s.Verdict();
    body << "<tr><td class=\"l\">" << HtmlEscape(name) << "</td><td>" << s.count() << "</td><td>"
         << s.conforms << "</td><td>" << s.fails << "</td><td>" << s.undetermined << "</td><td>"
         << Fixed(std::abs(w.error) / w.mpe, 3) << "</td><td class=\"l\">"
         << HtmlEscape(w.from + " - " + w.to) << "</td><td>" << Fixed(w.length, 3) << "</td><td>"
         << Fixed(w.error * 1e6, 1) << "</td><td>" << Fixed(w.U * 1e6, 1) << "</td><td class=\"l "
         << (verdict == "conforms" ? "ok" : "bad") << "\">" << verdict << "</td></tr>";
  }
  body << "</table></section>\n";
}

// Tasks over adjusted targets, with the ISO 14253-1 decision where a tolerance is given.
void TasksTable(std::ostringstream& body, const std::vector<NetworkTaskResult>& tasks) {
  body << "<section><h2>Tasks</h2><p class=\"note\">Over adjusted targets, whichever station read them, with "
          "their joint covariance through the adjustment (G C G<sup>T</sup>). Lengths: values and tolerances "
          "in mm, u and U in µm; angles (a cone's half angle): values and tolerances in deg, u and U in "
          "arcsec; directions dimensionless. n/a: no GUM value (a form quantity of points that fit "
          "exactly).</p><table><tr><th class=\"l\">task</th><th class=\"l\">quantity</th><th>value</th>"
          "<th>u</th><th>U</th><th class=\"l\">tolerance</th><th class=\"l\">decision (ISO 14253-1)</th></tr>";
  constexpr double kDegree = 180.0 / 3.14159265358979323846;
  for (const NetworkTaskResult& t : tasks) {
    for (std::size_t q = 0; q < t.quantities.size(); ++q) {
      const bool length = t.units[q] == "m", angle = t.units[q] == "rad";
      // The value to 0.1 µm (10^-6 degree) like the run's task table; u and U to three significant
      // digits; the tolerance in the value's unit.
      const std::string value = length  ? Fixed(t.value(q) * 1e3, 4) + " mm"
                                : angle ? Fixed(t.value(q) * kDegree, 6) + " deg"
                                        : Fixed(t.value(q), 8);
      const double u_scale = length ? 1e6 : angle ? 3600.0 * kDegree : 1.0;
      const std::string u_unit = length ? " µm" : angle ? " arcsec" : "";
      auto uncertainty = [&](double u) {
        return !t.differentiable[q] ? std::string("n/a") : base_internal::Sig(u * u_scale, 3) + u_unit;
      };
      std::string limits;
      if (q < t.limits.size() && t.limits[q]) {
        limits = length  ? DescribeTolerance(*t.limits[q], 1e3, "mm")
                 : angle ? DescribeTolerance(*t.limits[q], kDegree, "deg")
                         : DescribeTolerance(*t.limits[q], "");
      }
      body << "<tr><td class=\"l\">" << HtmlEscape(t.name) << "</td><td class=\"l\">"
           << HtmlEscape(t.quantities[q]) << "</td><td>" << value << "</td><td>" << uncertainty(t.u(q))
           << "</td><td>" << uncertainty(t.U(q)) << "</td><td class=\"l\">" << HtmlEscape(limits)
           << "</td><td class=\"l\">" << (t.conformity[q] ? HtmlEscape(t.conformity[q]->verdict) : "")
           << "</td></tr>";
    }
  }
  body << "</table></section>\n";
}

void SelfCalibratedTable(std::ostringstream& body, const NetworkResult& result) {
  body << "<section><h2>Self-calibrated parameters</h2><p class=\"note\">Estimated by the network with their "
          "prior as a pseudo-observation; "
          "u / prior u near 1: the network does not see the parameter.</p><table><tr><th "
          "class=\"l\">input</th><th class=\"l\">unit (SI)</th>"
          "<th>prior estimate</th><th>prior u</th><th>estimate</th><th>u</th><th>u / prior u</th></tr>";
  for (const CalibratedParameter& p : result.parameters) {
    body << "<tr><td class=\"l\">" << HtmlEscape(p.name) << "</td><td class=\"l\">" << HtmlEscape(p.unit)
         << "</td><td>" << Num(p.prior_estimate) << "</td><td>" << Num(p.prior_u) << "</td><td>"
         << Num(p.estimate) << "</td><td>" << Num(p.u) << "</td><td>" << Fixed(p.u / p.prior_u, 3)
         << "</td></tr>";
  }
  body << "</table></section>\n";
}

void IdentifiabilityTable(std::ostringstream& body, const NetworkResult& result) {
  body << "<section><h2>Identifiability of the self-calibrated inputs</h2><p class=\"note\">Combinations of "
          "the inputs (coefficients in "
          "each input's prior u), best determined first; data u / prior u is what the network alone would "
          "give, in units of the prior "
          "(above 1: the prior knows it better; inf: the network is blind to "
          "it).</p><table><tr><th>#</th><th>singular value</th>"
          "<th>data u / prior u</th><th class=\"l\">determined</th><th class=\"l\">combination</th></tr>";
  for (std::size_t i = 0; i < result.identifiability.size(); ++i) {
    const NetworkCombination& c = result.identifiability[i];
    body << "<tr><td>" << i + 1 << "</td><td>" << base_internal::Sig(c.singular_value, 4) << "</td><td>"
         << (std::isfinite(c.ratio) ? base_internal::Sig(c.ratio, 3) : std::string("inf"))
         << "</td><td class=\"l " << (c.determined ? "ok" : "na") << "\">" << (c.determined ? "yes" : "no")
         << "</td><td class=\"l\">" << HtmlEscape(c.description) << "</td></tr>";
  }
  body << "</table></section>\n";
}

// Baarda's data snooping: the readings flagged as outliers.
void FlaggedReadings(std::ostringstream& body, const NetworkJob& job, const NetworkResult& result) {
  body << "<section><h2>Flagged readings</h2><p class=\"note\">Baarda's data snooping: w = (residual / u) / "
          "sqrt(redundancy) without consider inputs; with them, the residual over its standard deviation "
          "in the model where the instruments' and the air's stated errors are random effects "
          "(docs/network.md N-8); flagged when "
          "|w| &gt; "
       << Fixed(job.network.outlier_limit, 2) << ". Every reading's residual is in residuals.csv.</p>";
  if (result.outliers == 0) {
    body << "<p>None.</p>";
  } else {
    body << "<table><tr><th class=\"l\">station</th><th class=\"l\">target</th><th class=\"l\">face</th><th "
            "class=\"l\">reading</th><th>residual</th>"
            "<th class=\"l\">unit</th><th>redundancy</th><th>w</th><th class=\"l\">where</th></tr>";
    for (const NetworkResidual& r : result.residuals) {
      if (!r.outlier) continue;
      const bool angle = r.unit == "rad";
      body << "<tr><td class=\"l\">" << HtmlEscape(r.station) << "</td><td class=\"l\">"
           << HtmlEscape(r.target) << "</td><td class=\"l\">" << FaceName(r.face) << "</td><td class=\"l\">"
           << r.component << "</td><td>" << Fixed(angle ? r.residual / kArcsec : r.residual * 1e6, 2)
           << "</td><td class=\"l\">" << (angle ? "arcsec" : "µm") << "</td><td>" << Fixed(r.redundancy, 3)
           << "</td><td class=\"bad\">" << Fixed(r.w, 2) << "</td><td class=\"l\">" << HtmlEscape(r.where)
           << "</td></tr>";
    }
    body << "</table>";
  }
  body << "</section>\n";
}

// Scale bars and measured distances at the solution (N-4a, N-8).
void DistancesTable(std::ostringstream& body, const NetworkResult& result) {
  body << "<section><h2>Scale bars and distances</h2><p class=\"note\">observed: the calibrated length "
          "corrected to the bar's temperature; adjusted: the distance of the adjusted targets, its u from "
          "the full covariance.</p><table><tr><th class=\"l\">name</th><th class=\"l\">kind</th>"
          "<th class=\"l\">from</th><th class=\"l\">to</th><th>observed (m)</th><th>u (µm)</th>"
          "<th>adjusted (m)</th><th>u (µm)</th><th>adjusted &minus; observed (µm)</th><th>redundancy</th>"
          "<th>w</th></tr>";
  for (const AdjustedDistance& d : result.distances) {
    body << "<tr><td class=\"l\">" << HtmlEscape(d.name) << "</td><td class=\"l\">"
         << (d.scale_bar ? "scale bar" : "distance") << "</td><td class=\"l\">" << HtmlEscape(d.from)
         << "</td><td class=\"l\">" << HtmlEscape(d.to) << "</td><td>" << Fixed(d.observed, 7) << "</td><td>"
         << Fixed(d.u_observed * 1e6, 2) << "</td><td>" << Fixed(d.adjusted, 7) << "</td><td>"
         << Fixed(d.u_adjusted * 1e6, 2) << "</td><td>" << Fixed((d.adjusted - d.observed) * 1e6, 2)
         << "</td><td>" << Fixed(d.redundancy, 3) << "</td><td" << (d.outlier ? " class=\"bad\"" : "") << ">"
         << Fixed(d.w, 2) << "</td></tr>";
  }
  body << "</table></section>\n";
}

// What the robust adjustment removed (N-8a), with w when removed and against the final adjustment.
void RejectedTable(std::ostringstream& body, const NetworkJob& job, const NetworkResult& result) {
  body << "<section><h2>Removed by the robust adjustment</h2><p class=\"note\">Iterative data snooping: "
          "the observation with the largest |w| above "
       << Fixed(result.rejection_limit, 2) << " (probability " << Num(job.network.robust_alpha)
       << " of removing any good observation) is removed and the network re-adjusted, until none "
          "exceeds it. w after: its misfit to the final adjustment, which no longer contains it.</p>";
  if (result.rejected.empty()) {
    body << "<p>None.</p>";
  } else {
    body << "<table><tr><th>#</th><th class=\"l\">station</th><th class=\"l\">target / distance</th>"
            "<th class=\"l\">face</th><th class=\"l\">component</th><th>w when removed</th><th>w after</th>"
            "<th class=\"l\">where</th></tr>";
    for (std::size_t i = 0; i < result.rejected.size(); ++i) {
      const RejectedObservation& r = result.rejected[i];
      body << "<tr><td>" << i + 1 << "</td><td class=\"l\">" << HtmlEscape(r.station)
           << "</td><td class=\"l\">" << HtmlEscape(r.target) << "</td><td class=\"l\">"
           << (r.distance ? "" : FaceName(r.face)) << "</td><td class=\"l\">" << r.component
           << "</td><td class=\"bad\">" << Fixed(r.w_before, 2) << "</td><td>"
           << (r.predicted ? Fixed(r.w_after, 2) : std::string("n/a")) << "</td><td class=\"l\">"
           << HtmlEscape(r.where) << "</td></tr>";
    }
    body << "</table>";
  }
  body << "</section>\n";
}

// report.html: the network in 3-D (stations, targets coloured by |U|, lines of sight, the axes of
// every target's coverage ellipsoid, exaggerated), then the tables a metrologist signs.
std::string NetworkReport(const NetworkJob& job, const NetworkResult& result, const NetworkMonteCarlo* mc,
                          const std::vector<NetworkTaskResult>& tasks,
                          const std::vector<NetworkLengthError>& lengths) {
  std::ostringstream body, script;
  AdjustmentSection(body, job, result, mc);
  if (!result.warnings.empty()) {
    body << "<section><h2>Warnings</h2>";
    for (const std::string& w : result.warnings) body << "<p class=\"bad\">" << HtmlEscape(w) << "</p>";
    body << "</section>\n";
  }
  NetworkView(body, script, job, result);
  // Tables.
  TargetsTable(body, result);
  StationsTable(body, result);
  if (AnyDrift(result)) DriftSection(body, script, job, result);
  if (job.length_test) LengthTestSection(body, job, lengths);
  for (const NetworkStation& st : job.network.stations) {
    if (st.environment) {
      StationAirTable(body, job.network, TimeOrigin(job.network));
      break;
    }
  }
  if (!tasks.empty()) TasksTable(body, tasks);
  if (!result.parameters.empty()) SelfCalibratedTable(body, result);
  if (!result.identifiability.empty()) IdentifiabilityTable(body, result);
  if (!result.distances.empty()) DistancesTable(body, result);
  FlaggedReadings(body, job, result);
  if (job.network.robust) RejectedTable(body, job, result);
  return output_internal::Page(
      "vlt network — " + job.name,
      job.description.empty() ? "Bundle adjustment of a network of stations" : job.description, body.str(),
      script.str());
}

std::string TargetsCsv(const NetworkResult& result) {
  std::string s = "name,x_m,y_m,z_m,u_x_m,u_y_m,u_z_m,U_x_m,U_y_m,U_z_m,stations,readings,reference\n";
  for (const AdjustedTarget& t : result.targets) {
    s += Csv(t.name);
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, t.position(c));
    }
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, std::sqrt(t.covariance(c, c)));
    }
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, result.k * std::sqrt(t.covariance(c, c)));
    }
    s += ',';
    s += std::to_string(t.stations);
    s += ',';
    s += std::to_string(t.readings);
    s += t.reference ? ",true\n" : ",false\n";
  }
  return s;
}

std::string StationsCsv(const NetworkResult& result) {
  std::string s =
      "name,datum,rx_rad,ry_rad,rz_rad,tx_m,ty_m,tz_m,u_rx_rad,u_ry_rad,u_rz_rad,u_tx_m,u_ty_m,u_tz_m,"
      "readings\n";
  for (const AdjustedStation& st : result.stations) {
    s += Csv(st.name);
    s += st.datum ? ",true" : ",false";
    for (int c = 0; c < 6; ++c) {
      s += ',';
      AppendNum(s, st.pose(c));
    }
    for (int c = 0; c < 6; ++c) {
      s += ',';
      AppendNum(s, std::sqrt(st.covariance(c, c)));
    }
    s += ',';
    s += std::to_string(st.readings);
    s += '\n';
  }
  return s;
}

// length_test.csv (N-13): every length of every station.
std::string LengthTestCsv(const std::vector<NetworkLengthError>& errors) {
  std::string s = "station,from,to,length_m,error_m,u_m,U_m,mpe_m,error_over_mpe,decision\n";
  for (const NetworkLengthError& e : errors) {
    s += Csv(e.station) + "," + Csv(e.from) + "," + Csv(e.to);
    for (double v : {e.length, e.error, e.u, e.U, e.mpe, std::abs(e.error) / e.mpe}) {
      s += ',';
      AppendNum(s, v);
    }
    s += "," + e.decision.verdict + "\n";
  }
  return s;
}

nlohmann::ordered_json LengthTestJson(const NetworkLengthTest& test,
                                      const std::vector<NetworkLengthError>& errors) {
  LengthTestSummary all;
  for (const NetworkLengthError& e : errors) all.Add(e);
  nlohmann::ordered_json o;
  o["mpe_a"] = test.mpe_a;
  o["mpe_b"] = test.mpe_b;
  o["min_length"] = test.min_length;
  o["lengths"] = all.count();
  o["conforms"] = all.conforms;
  o["does_not_conform"] = all.fails;
  o["undetermined"] = all.undetermined;
  o["verdict"] = all.count() > 0 ? nlohmann::ordered_json(all.Verdict()) : nlohmann::ordered_json(nullptr);
  if (all.worst) {
    const NetworkLengthError& w = *all.worst;
    o["worst"] = {{"station", w.station}, {"from", w.from}, {"to", w.to},   {"length", w.length},
                  {"error", w.error},     {"U", w.U},       {"mpe", w.mpe}, {"decision", w.decision.verdict}};
  } else {
    o["worst"] = nullptr;
  }
  return o;
}

// The summary's line of the length test (N-13).
std::string LengthTestLine(const NetworkJob& job, const NetworkResult& result) {
  LengthTestSummary all;
  const std::vector<NetworkLengthError> lengths = NetworkLengthErrors(job.network, result, *job.length_test);
  for (const NetworkLengthError& e : lengths) all.Add(e);
  char line[768];
  if (!all.worst) {
    std::snprintf(line, sizeof line,
                  "Length test: no pair of targets read by one station is %.2f m or longer\n",
                  job.length_test->min_length);
    return line;
  }
  // A difference that rounds to 0.0 um prints as 0.0, not -0.0.
  const double e_um = std::abs(all.worst->error) < 5e-8 ? 0.0 : all.worst->error * 1e6;
  std::snprintf(
      line, sizeof line,
      "Length test (ISO 10360-10 from the network, MPE %.1f µm + %.2f µm/m): %d lengths of at least %.2f m, "
      "%d conform, %d do not, %d undetermined; largest |E| / MPE %.3f (%s, %.40s - %.40s: E %.1f µm, U "
      "%.1f µm): %s (length_test.csv)\n",
      job.length_test->mpe_a * 1e6, job.length_test->mpe_b * 1e6, all.count(), job.length_test->min_length,
      all.conforms, all.fails, all.undetermined, std::abs(all.worst->error) / all.worst->mpe,
      all.worst->station.c_str(), all.worst->from.c_str(), all.worst->to.c_str(), e_um, all.worst->U * 1e6,
      all.Verdict().c_str());
  return line;
}

// drift.csv (N-12): every knot of every drifting station.
std::string DriftCsv(const NetworkJob& job, const NetworkResult& result) {
  std::string s =
      "station,knot,time_s,elapsed_h,drx_rad,dry_rad,drz_rad,dtx_m,dty_m,dtz_m,u_drx_rad,u_dry_rad,u_drz_rad,"
      "u_dtx_m,u_dty_m,u_dtz_m\n";
  const double origin = TimeOrigin(job.network);
  for (const AdjustedStation& st : result.stations) {
    for (std::size_t k = 0; k < st.drift.size(); ++k) {
      const AdjustedDriftEpoch& e = st.drift[k];
      s += Csv(st.name) + "," + std::to_string(k) + ",";
      AppendNum(s, e.time);
      s += ',';
      AppendNum(s, (e.time - origin) / 3600.0);
      for (int c = 0; c < 6; ++c) {
        s += ',';
        AppendNum(s, e.offset(c));
      }
      for (int c = 0; c < 6; ++c) {
        s += ',';
        AppendNum(s, std::sqrt(std::max(0.0, e.covariance(c, c))));
      }
      s += '\n';
    }
  }
  return s;
}

std::string ResidualsCsv(const NetworkResult& result) {
  std::string s = "station,target,face,reading,unit,residual,u,normalised,redundancy,w,outlier,where\n";
  for (const NetworkResidual& r : result.residuals) {
    s += Csv(r.station) + "," + Csv(r.target) + "," + FaceName(r.face) + "," + r.component + "," + r.unit;
    for (double v : {r.residual, r.u, r.normalised, r.redundancy, r.w}) {
      s += ',';
      AppendNum(s, v);
    }
    s += std::string(",") + (r.outlier ? "true" : "false") + "," + Csv(r.where) + "\n";
  }
  return s;
}

std::string DistancesCsv(const NetworkResult& result) {
  std::string s =
      "name,kind,from,to,observed_m,u_observed_m,adjusted_m,u_adjusted_m,normalised,redundancy,w,outlier,"
      "where\n";
  for (const AdjustedDistance& d : result.distances) {
    s += Csv(d.name) + (d.scale_bar ? ",scale_bar," : ",distance,") + Csv(d.from) + "," + Csv(d.to);
    for (double v : {d.observed, d.u_observed, d.adjusted, d.u_adjusted, d.normalised, d.redundancy, d.w}) {
      s += ',';
      AppendNum(s, v);
    }
    s += std::string(",") + (d.outlier ? "true" : "false") + "," + Csv(d.where) + "\n";
  }
  return s;
}

// rejected.csv: in the order removed; w_after empty where the target left the network with it.
std::string RejectedCsv(const NetworkResult& result) {
  std::string s = "order,kind,station,target,face,component,w_before,w_after,where\n";
  for (std::size_t i = 0; i < result.rejected.size(); ++i) {
    const RejectedObservation& r = result.rejected[i];
    // (Appended piece by piece: GCC 12 warns falsely on a long chain of std::string + at -O3.)
    s += std::to_string(i + 1);
    s += r.distance ? ",distance," : ",reading,";
    s += Csv(r.station);
    s += ',';
    s += Csv(r.target);
    s += ',';
    if (!r.distance) s += FaceName(r.face);
    s += ',';
    s += r.component;
    s += ',';
    AppendNum(s, r.w_before);
    s += ',';
    if (r.predicted) AppendNum(s, r.w_after);
    s += ',';
    s += Csv(r.where);
    s += '\n';
  }
  return s;
}

// covariance.csv: the full matrix, SI (m^2, m rad, rad^2, ...), labelled rows and columns.
std::string CovarianceCsv(const NetworkResult& result) {
  std::string s = "unknown";
  for (const std::string& name : result.unknown_names) {
    s += ',';
    s += Csv(name);
  }
  s += "\n";
  for (Eigen::Index r = 0; r < result.covariance.rows(); ++r) {
    s += Csv(result.unknown_names[r]);
    for (Eigen::Index c = 0; c < result.covariance.cols(); ++c) {
      s += ',';
      AppendNum(s, result.covariance(r, c));
    }
    s += '\n';
  }
  return s;
}

std::string TasksCsv(const std::vector<NetworkTaskResult>& tasks) {
  std::string s =
      "task,kind,quantity,unit,value,u,U,differentiable,tolerance,decision,probability_of_conformity\n";
  for (const NetworkTaskResult& t : tasks) {
    for (std::size_t q = 0; q < t.quantities.size(); ++q) {
      s += Csv(t.name) + "," + std::string(TaskKindName(t.kind)) + "," + t.quantities[q] + "," + t.units[q];
      for (double v : {t.value(q), t.u(q), t.U(q)}) {
        s += ',';
        AppendNum(s, v);
      }
      s += t.differentiable[q] ? ",true," : ",false,";
      s += Csv(t.tolerance[q]);
      s += ',';
      if (t.conformity[q]) {
        s += Csv(t.conformity[q]->verdict);
        s += ',';
        if (t.conformity[q]->probability_gum) AppendNum(s, *t.conformity[q]->probability_gum);
      } else {
        s += ',';
      }
      s += '\n';
    }
  }
  return s;
}

// GUM and Monte Carlo standard uncertainties side by side, and the Monte Carlo bias.
std::string McmCsv(const NetworkResult& result, const NetworkMonteCarlo& mc) {
  std::string s =
      "name,u_x_gum_m,u_y_gum_m,u_z_gum_m,u_x_mcm_m,u_y_mcm_m,u_z_mcm_m,bias_x_m,bias_y_m,bias_z_m\n";
  for (std::size_t t = 0; t < result.targets.size(); ++t) {
    s += Csv(result.targets[t].name);
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, std::sqrt(result.targets[t].covariance(c, c)));
    }
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, std::sqrt(mc.covariance[t](c, c)));
    }
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, mc.bias[t](c));
    }
    s += '\n';
  }
  return s;
}

std::string IdentifiabilityCsv(const NetworkResult& result) {
  std::string s = "combination,singular_value,data_u_over_prior_u,determined,inputs\n";
  for (std::size_t i = 0; i < result.identifiability.size(); ++i) {
    const NetworkCombination& c = result.identifiability[i];
    s += std::to_string(i + 1);
    s += ',';
    AppendNum(s, c.singular_value);
    s += ',';
    if (std::isfinite(c.ratio))
      AppendNum(s, c.ratio);
    else
      s += "inf";
    s += c.determined ? ",true," : ",false,";
    s += Csv(c.description);
    s += '\n';
  }
  return s;
}

std::string ParametersCsv(const NetworkResult& result) {
  // u_over_prior: 1 where the network does not see the parameter, toward 0 where it determines it.
  std::string s = "name,unit,prior_estimate,prior_u,estimate,u,u_over_prior\n";
  for (const CalibratedParameter& p : result.parameters) {
    s += Csv(p.name) + "," + p.unit;
    for (double v : {p.prior_estimate, p.prior_u, p.estimate, p.u, p.u / p.prior_u}) {
      s += ',';
      AppendNum(s, v);
    }
    s += '\n';
  }
  return s;
}

nlohmann::ordered_json JobJson(const NetworkJob& job) {
  nlohmann::ordered_json meta;
  meta["name"] = job.name;
  meta["description"] = job.description;
  meta["record"] = output_internal::RecordJson(job.record);
  meta["file"] = job.file;
  meta["mode"] = job.offline ? "plan" : "readings";
  nlohmann::ordered_json instruments = nlohmann::ordered_json::array();
  for (const NetworkInstrument& in : job.network.instruments)
    instruments.push_back({{"name", in.name}, {"model", in.setup.model->name}});
  meta["instruments"] = instruments;
  meta["coverage_probability"] = job.network.coverage_probability;
  meta["self_calibrate"] = job.network.self_calibrate;
  nlohmann::ordered_json inputs = nlohmann::ordered_json::array();
  for (const InputFile& f : job.input_files)
    inputs.push_back({{"role", f.role}, {"path", f.path}, {"sha256", f.sha256.empty() ? Sha256File(f.path) : f.sha256}});
  meta["input_files"] = inputs;
  return meta;
}

// A station's drift model and its knots (N-12); null without one.
// An air of a station (N-2a): estimates and u in degC, K, Pa, %, and its sensor ("" for none).
nlohmann::ordered_json AirJson(const Environment& air, const std::string& sensor) {
  return {{"temperature", air.temperature.estimate},
          {"u_temperature", air.temperature.u},
          {"pressure", air.pressure.estimate},
          {"u_pressure", air.pressure.u},
          {"humidity", air.humidity.estimate},
          {"u_humidity", air.humidity.u},
          {"sensor", sensor}};
}

nlohmann::ordered_json DriftJson(const NetworkDrift& drift, const AdjustedStation& st, double origin) {
  if (!drift.enabled) return nullptr;
  nlohmann::ordered_json o;
  o["model"] = "linear";
  o["translation_rate"] = drift.translation_rate;
  o["rotation_rate"] = drift.rotation_rate;
  nlohmann::ordered_json knots = nlohmann::ordered_json::array();
  for (const AdjustedDriftEpoch& e : st.drift) {
    std::vector<double> offset(6), u(6);
    for (int c = 0; c < 6; ++c) {
      offset[c] = e.offset(c);
      u[c] = std::sqrt(std::max(0.0, e.covariance(c, c)));
    }
    knots.push_back(
        {{"time", e.time}, {"elapsed_h", (e.time - origin) / 3600.0}, {"offset", offset}, {"u", u}});
  }
  o["knots"] = knots;
  return o;
}

nlohmann::ordered_json StationsJson(const NetworkJob& job, const NetworkResult& result) {
  const double origin = TimeOrigin(job.network);  // of the drift knots' elapsed hours
  nlohmann::ordered_json stations = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < result.stations.size(); ++i) {
    const AdjustedStation& st = result.stations[i];
    nlohmann::ordered_json o;
    o["name"] = st.name;
    o["instrument"] = job.network.instruments[job.network.stations[i].instrument].name;
    o["datum"] = st.datum;
    o["readings"] = st.readings;
    for (int c = 0; c < 6; ++c) o[kPoseNames[c]] = st.pose(c);
    std::vector<double> u(6);
    for (int c = 0; c < 6; ++c) u[c] = std::sqrt(st.covariance(c, c));
    o["u"] = u;
    // The station's own air (N-2a): estimates and u in degC, K, Pa, %; null when it has the instrument's.
    // Air that changes while it reads: `air_changes`, each from `time` [s] (`elapsed_h`) on.
    const NetworkStation& station = job.network.stations[i];
    if (station.environment) {
      o["air"] = AirJson(*station.environment, station.air_sensor);
      nlohmann::ordered_json changes = nlohmann::ordered_json::array();
      for (const NetworkAirChange& change : station.air_changes) {
        nlohmann::ordered_json c = {{"time", change.from}, {"elapsed_h", (change.from - origin) / 3600.0}};
        c.update(AirJson(change.environment, change.sensor));
        changes.push_back(c);
      }
      o["air_changes"] = changes;
    } else {
      o["air"] = nullptr;
      o["air_changes"] = nlohmann::ordered_json::array();
    }
    o["drift"] = DriftJson(job.network.stations[i].drift, st, origin);
    stations.push_back(o);
  }
  return stations;
}

nlohmann::ordered_json TargetsJson(const NetworkResult& result) {
  nlohmann::ordered_json targets = nlohmann::ordered_json::array();
  for (const AdjustedTarget& t : result.targets) {
    nlohmann::ordered_json o;
    o["name"] = t.name;
    o["position"] = {t.position(0), t.position(1), t.position(2)};
    nlohmann::ordered_json cov = nlohmann::ordered_json::array();
    for (int r = 0; r < 3; ++r) cov.push_back({t.covariance(r, 0), t.covariance(r, 1), t.covariance(r, 2)});
    o["covariance"] = cov;
    std::vector<double> U(3);
    for (int c = 0; c < 3; ++c) U[c] = result.k * std::sqrt(t.covariance(c, c));
    o["U"] = U;
    o["stations"] = t.stations;
    o["reference"] = t.reference;
    targets.push_back(o);
  }
  return targets;
}

nlohmann::ordered_json ParametersJson(const NetworkResult& result) {
  nlohmann::ordered_json params = nlohmann::ordered_json::array();
  for (const CalibratedParameter& p : result.parameters) {
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"prior_estimate", p.prior_estimate},
                      {"prior_u", p.prior_u},
                      {"estimate", p.estimate},
                      {"u", p.u},
                      {"u_over_prior", p.u / p.prior_u}});
  }
  return params;
}

nlohmann::ordered_json IdentifiabilityJson(const NetworkResult& result) {
  nlohmann::ordered_json ident = nlohmann::ordered_json::array();
  for (const NetworkCombination& c : result.identifiability) {
    nlohmann::ordered_json o = {
        {"singular_value", c.singular_value}, {"determined", c.determined}, {"inputs", c.description}};
    // Blind combinations have no finite ratio: JSON has no infinity, so null.
    if (std::isfinite(c.ratio))
      o["data_u_over_prior_u"] = c.ratio;
    else
      o["data_u_over_prior_u"] = nullptr;
    ident.push_back(o);
  }
  return ident;
}

nlohmann::ordered_json DistancesJson(const NetworkResult& result) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const AdjustedDistance& d : result.distances) {
    out.push_back({{"name", d.name},
                   {"kind", d.scale_bar ? "scale_bar" : "distance"},
                   {"from", d.from},
                   {"to", d.to},
                   {"observed", d.observed},
                   {"u_observed", d.u_observed},
                   {"adjusted", d.adjusted},
                   {"u_adjusted", d.u_adjusted},
                   {"redundancy", d.redundancy},
                   {"w", d.w},
                   {"outlier", d.outlier}});
  }
  return out;
}

nlohmann::ordered_json RobustJson(const Network& network, const NetworkResult& result) {
  nlohmann::ordered_json rejected = nlohmann::ordered_json::array();
  for (const RejectedObservation& r : result.rejected) {
    nlohmann::ordered_json o = {{"kind", r.distance ? "distance" : "reading"},
                                {"station", r.station},
                                {"target", r.target},
                                {"component", r.component},
                                {"w_before", r.w_before}};
    if (!r.distance) o["face"] = FaceName(r.face);
    if (r.predicted)
      o["w_after"] = r.w_after;
    else
      o["w_after"] = nullptr;
    o["where"] = r.where;
    rejected.push_back(o);
  }
  return {
      {"alpha", network.robust_alpha}, {"rejection_limit", result.rejection_limit}, {"rejected", rejected}};
}

nlohmann::ordered_json TasksJson(const std::vector<NetworkTaskResult>& tasks) {
  nlohmann::ordered_json task_json = nlohmann::ordered_json::array();
  for (const NetworkTaskResult& t : tasks) {
    nlohmann::ordered_json quantities = nlohmann::ordered_json::array();
    for (std::size_t q = 0; q < t.quantities.size(); ++q) {
      nlohmann::ordered_json o = {{"name", t.quantities[q]},
                                  {"unit", t.units[q]},
                                  {"value", t.value(q)},
                                  {"differentiable", static_cast<bool>(t.differentiable[q])}};
      if (t.differentiable[q]) {
        o["u"] = t.u(q);
        o["U"] = t.U(q);
      }
      if (!t.tolerance[q].empty()) o["tolerance"] = t.tolerance[q];
      if (t.conformity[q]) {
        o["decision"] = t.conformity[q]->verdict;
        if (t.conformity[q]->probability_gum)
          o["probability_of_conformity"] = *t.conformity[q]->probability_gum;
      }
      quantities.push_back(o);
    }
    task_json.push_back({{"name", t.name},
                         {"kind", std::string(TaskKindName(t.kind))},
                         {"weighting", t.weighted ? "covariance" : "none"},
                         {"quantities", quantities}});
  }
  return task_json;
}

// results.json (schema vlt-network/1, docs/network.md); `files` are the files written before it.
std::string ResultsJson(const NetworkJob& job, const NetworkResult& result,
                        const std::vector<NetworkTaskResult>& tasks, const std::string& created,
                        const NetworkMonteCarlo* mc, const Files& files,
                        const std::vector<NetworkLengthError>& lengths) {
  nlohmann::ordered_json j;
  j["schema"] = "vlt-network/1";
  j["created"] = created;
  j["vlt_version"] = VLT_VERSION;
  j["vlt_commit"] = VltCommit();
  // Every number is SI; pose angles rx, ry, rz in rad (R = Rz Ry Rx, x_part = R x_station + t).
  j["units"] = {{"length", "m"}, {"angle", "rad"}, {"covariance", "SI products (m^2, m rad, rad^2)"}};
  j["job"] = JobJson(job);
  j["summary"] = {{"observations", result.observations},
                  {"unknowns", result.unknowns},
                  {"dof", result.dof},
                  {"chi2", result.chi2},
                  {"birge_ratio", result.birge_ratio},
                  {"p_value", result.p_value},
                  {"chi2_random_effects", result.chi2_random_effects},
                  {"p_value_random_effects", result.p_value_random_effects},
                  {"outliers", result.outliers},
                  {"iterations", result.iterations},
                  {"k", result.k},
                  {"share_noise", result.share_noise},
                  {"share_consider", result.share_consider}};
  j["warnings"] = result.warnings;
  j["stations"] = StationsJson(job, result);
  j["targets"] = TargetsJson(result);
  j["parameters"] = ParametersJson(result);
  if (!result.identifiability.empty()) j["identifiability"] = IdentifiabilityJson(result);
  if (!result.distances.empty()) j["distances"] = DistancesJson(result);
  if (job.network.robust) j["robust"] = RobustJson(job.network, result);
  j["tasks"] = TasksJson(tasks);
  if (job.length_test) j["length_test"] = LengthTestJson(*job.length_test, lengths);
  if (mc) {
    j["monte_carlo"] = {{"trials", mc->trials},
                        {"seed", mc->seed},
                        {"ranks", mc->ranks},
                        {"tolerance", mc->tolerance},
                        {"worst_ratio", mc->worst_ratio},
                        {"worst", mc->worst},
                        {"agrees", mc->agrees}};
  }
  std::vector<std::string> names;
  for (const auto& f : files) names.push_back(f.first);
  names.push_back("results.json");
  j["files"] = names;
  return j.dump(1) + "\n";
}

}  // namespace

Files NetworkFiles(const NetworkJob& job, const NetworkResult& result,
                   const std::vector<NetworkTaskResult>& tasks, const std::string& created,
                   const NetworkMonteCarlo* mc) {
  Files files;
  files.emplace_back("targets.csv", TargetsCsv(result));
  files.emplace_back("stations.csv", StationsCsv(result));
  files.emplace_back("residuals.csv", ResidualsCsv(result));
  if (AnyDrift(result)) files.emplace_back("drift.csv", DriftCsv(job, result));
  std::vector<NetworkLengthError> lengths;
  if (job.length_test) {
    lengths = NetworkLengthErrors(job.network, result, *job.length_test);
    files.emplace_back("length_test.csv", LengthTestCsv(lengths));
  }
  files.emplace_back("covariance.csv", CovarianceCsv(result));
  if (!result.distances.empty()) files.emplace_back("distances.csv", DistancesCsv(result));
  if (!result.rejected.empty()) files.emplace_back("rejected.csv", RejectedCsv(result));
  if (!tasks.empty()) files.emplace_back("tasks.csv", TasksCsv(tasks));
  if (mc) files.emplace_back("mcm.csv", McmCsv(result, *mc));
  if (!result.identifiability.empty()) files.emplace_back("identifiability.csv", IdentifiabilityCsv(result));
  if (!result.parameters.empty()) files.emplace_back("parameters.csv", ParametersCsv(result));
  files.emplace_back("report.html", NetworkReport(job, result, mc, tasks, lengths));
  files.emplace_back("results.json", ResultsJson(job, result, tasks, created, mc, files, lengths));
  return files;
}

std::string NetworkSummary(const NetworkJob& job, const NetworkResult& result, const NetworkMonteCarlo* mc) {
  double worst = 0.0;
  std::string worst_name;
  for (const AdjustedTarget& t : result.targets) {
    const double U = result.k * std::sqrt(t.covariance.trace());
    if (U > worst) {
      worst = U;
      worst_name = t.name;
    }
  }
  char line[512];
  // A plan's readings are the model's own (no noise): its chi2, Birge ratio and outliers are 0 by
  // construction and say nothing; what it gives is the predicted U (issue 34).
  char fit[128] = "predicted:";
  if (!job.offline) {
    std::snprintf(fit, sizeof fit, "chi2 %.4g, Birge ratio %.3f, %d outlier%s;", result.chi2,
                  result.birge_ratio, result.outliers, result.outliers == 1 ? "" : "s");
  }
  std::snprintf(
      line, sizeof line,
      "%s network '%s': %zu station%s, %zu targets, %d observations, %d unknowns, dof %d; %s largest "
      "|U| (k = %.2f) %.1f µm at %s; variance from reading noise and references %.0f %%, from the "
      "instruments' errors and the air %.0f %%",
      job.offline ? "Planned" : "Measured", job.name.c_str(), result.stations.size(),
      result.stations.size() == 1 ? "" : "s", result.targets.size(), result.observations, result.unknowns,
      result.dof, fit, result.k, worst * 1e6, worst_name.c_str(), 100.0 * result.share_noise,
      100.0 * result.share_consider);
  std::string out = std::string(line) + "\n" + output_internal::RecordLine(job.record);
  if (!result.distances.empty()) {
    const auto worst_w = std::max_element(
        result.distances.begin(), result.distances.end(),
        [](const AdjustedDistance& a, const AdjustedDistance& b) { return std::abs(a.w) < std::abs(b.w); });
    std::snprintf(line, sizeof line,
                  "Scale bars and distances: %zu; largest |w| %.2f at %s (distances.csv)\n",
                  result.distances.size(), std::abs(worst_w->w), worst_w->name.c_str());
    out += line;
  }
  if (!result.rejected.empty()) {
    std::snprintf(line, sizeof line,
                  "Robust adjustment: %zu observation%s removed (|w| above %.2f; rejected.csv):",
                  result.rejected.size(), result.rejected.size() == 1 ? "" : "s", result.rejection_limit);
    out += line;
    for (const RejectedObservation& r : result.rejected) {
      std::snprintf(line, sizeof line, " %s%s%s (w %.1f)", r.station.c_str(), r.station.empty() ? "" : "/",
                    r.target.c_str(), r.w_before);
      out += line;
    }
    out += "\n";
  }
  if (job.length_test) out += LengthTestLine(job, result);
  for (const AdjustedStation& st : result.stations) {
    if (st.drift.empty()) continue;
    const AdjustedDriftEpoch& last = st.drift.back();
    const double hours = (last.time - st.drift.front().time) / 3600.0,
                 U = DriftTranslationU(result, last) * 1e6;
    if (job.offline) {  // planned: no drift was measured; the checks leave this U of it
      std::snprintf(
          line, sizeof line,
          "Drift of station %s over %.2f h (%zu knots): predicted U %.1f µm at the last knot (k = %.2f; "
          "drift.csv)\n",
          st.name.c_str(), hours, st.drift.size(), U, result.k);
    } else {
      std::snprintf(line, sizeof line,
                    "Drift of station %s over %.2f h (%zu knots): %.1f µm, U %.1f µm (k = %.2f; drift.csv)\n",
                    st.name.c_str(), hours, st.drift.size(), last.offset.tail<3>().norm() * 1e6, U, result.k);
    }
    out += line;
  }
  for (const std::string& w : result.warnings) out += "Warning: " + w + "\n";
  if (!result.identifiability.empty()) {
    int determined = 0;
    for (const NetworkCombination& c : result.identifiability) determined += c.determined ? 1 : 0;
    std::snprintf(line, sizeof line,
                  "Self-calibration: %d of %zu combinations of the %zu inputs determined by the network "
                  "alone better than by "
                  "their priors (identifiability.csv)\n",
                  determined, result.identifiability.size(), result.parameters.size());
    out += line;
  }
  if (mc) {
    std::snprintf(
        line, sizeof line,
        "Monte Carlo (%d re-adjusted simulated networks): u_MCM / u_GUM farthest from 1 is %.3f at %s; %s "
        "(tolerance +- %.3f)\n",
        mc->trials, mc->worst_ratio, mc->worst.c_str(),
        mc->agrees ? "the GUM agrees" : "the GUM does NOT agree", mc->tolerance);
    out += line;
  }
  return out;
}

}  // namespace vlt::network_outputs

namespace vlt::network_outputs {

namespace {

// A station's simulated readings that `keep` selects, as a readings CSV (range m, angles rad; with
// the column `time` [s] when the readings have their planned times, N-12).
template <class Keep>
std::string SimulatedReadingsCsv(const NetworkStation& st, const Keep& keep) {
  const bool timed = std::any_of(st.readings.begin(), st.readings.end(),
                                 [](const TargetReading& r) { return r.time.has_value(); });
  std::string s = timed ? "name,range,azimuth,elevation,face,time\n" : "name,range,azimuth,elevation,face\n";
  for (const TargetReading& r : st.readings) {
    if (!keep(r)) continue;
    s += Csv(r.target);
    for (int c = 0; c < 3; ++c) {
      s += ',';
      AppendNum(s, r.readings(c));
    }
    s += ',';
    s += FaceName(r.face);
    if (timed) {
      s += ',';
      AppendNum(s, r.time.value_or(0.0));
    }
    s += '\n';
  }
  return s;
}

}  // namespace

Files SimulatedNetworkFiles(const NetworkJob& job, const Network& simulated, std::uint64_t seed) {
  Files files;
  toml::table root = toml::parse(job.text);
  root.erase("targets");
  root.erase("output");
  if (!root["job"].as_table()) root.insert_or_assign("job", toml::table{});
  root["job"].as_table()->insert_or_assign("name", job.name + "-simulated-" + std::to_string(seed));
  // A calibration file named relative to the network file: absolute, since the simulated file
  // lives in the output directory.
  if (toml::table* tracker = root["tracker"].as_table()) {
    if (const auto* cal = tracker->get_as<std::string>("calibration")) {
      const std::string absolute =
          std::filesystem::absolute(job.base_dir / cal->get()).lexically_normal().string();
      tracker->insert_or_assign("calibration", absolute);
    }
  }
  // Each file's own name: SafeFileName maps "S/1" and "S 1" alike (to S_1), and one station's
  // readings overwrote the other's; a name taken already (compared without case, for file systems
  // that ignore it) gets _2, _3, ...
  std::set<std::string> taken;
  auto unique_csv = [&](const std::string& stem) {
    auto lowercase = [](std::string text) {
      for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      return text;
    };
    std::string name = stem + ".csv";
    for (int n = 2; !taken.insert(lowercase(name)).second; ++n) name = stem + "_" + std::to_string(n) + ".csv";
    return name;
  };
  toml::array* stations = root["station"].as_array();
  for (std::size_t i = 0; i < simulated.stations.size(); ++i) {
    const NetworkStation& st = simulated.stations[i];
    const std::string csv = unique_csv("simulated_" + base_internal::SafeFileName(st.name));
    // A drift check's readings go to its own file (below), as a measured check's come.
    files.emplace_back(csv, SimulatedReadingsCsv(st, [&](const TargetReading& r) {
                         return std::find(job.drift_check_where.begin(), job.drift_check_where.end(),
                                          r.where) == job.drift_check_where.end();
                       }));
    if (stations && i < stations->size()) {
      if (toml::table* t = stations->get(i)->as_table()) {
        t->erase("sees");
        t->erase("face");
        t->insert_or_assign("readings", toml::table{{"csv", csv}});
        if (toml::table* drift = (*t)["drift"].as_table())
          drift->erase("interval");  // the times are in the file
      }
    }
  }
  // Planned drift checks (N-12): each one's simulated readings in its own file, read at its time.
  if (toml::array* checks = root["drift_check"].as_array()) {
    for (std::size_t k = 0; k < checks->size() && k < job.drift_check_where.size(); ++k) {
      toml::table* t = checks->get(k)->as_table();
      const auto* station = t ? t->get_as<std::string>("station") : nullptr;
      if (!station) continue;
      for (const NetworkStation& st : simulated.stations) {
        if (st.name != station->get()) continue;
        // Numbered per station, in the file's order: the station's first check is check1.
        int number = 1;
        for (std::size_t j = 0; j < k; ++j) {
          const toml::table* earlier = checks->get(j)->as_table();
          const auto* other = earlier ? earlier->get_as<std::string>("station") : nullptr;
          if (other && other->get() == st.name) ++number;
        }
        const std::string csv =
            unique_csv("simulated_" + base_internal::SafeFileName(st.name) + "_check" + std::to_string(number));
        files.emplace_back(csv, SimulatedReadingsCsv(st, [&](const TargetReading& r) {
                             return r.where == job.drift_check_where[k];
                           }));
        t->erase("sees");
        t->erase("face");
        t->insert_or_assign("readings", toml::table{{"csv", csv}});
      }
    }
  }
  if (toml::array* refs = root["reference"].as_array()) {
    for (std::size_t r = 0; r < refs->size() && r < simulated.references.size(); ++r) {
      if (toml::table* t = refs->get(r)->as_table()) {
        t->insert_or_assign("x", simulated.references[r].position(0));
        t->insert_or_assign("y", simulated.references[r].position(1));
        t->insert_or_assign("z", simulated.references[r].position(2));
      }
    }
  }
  // Scale bars, then distances, in the file's order (the reader's): their simulated lengths.
  std::size_t next = 0;
  for (const char* key : {"scale_bar", "distance"}) {
    toml::array* tables = root[key].as_array();
    for (std::size_t k = 0; tables && k < tables->size() && next < simulated.distances.size(); ++k, ++next) {
      const NetworkDistance& d = simulated.distances[next];
      if (toml::table* t = tables->get(k)->as_table())
        t->insert_or_assign("length", d.scale_bar ? d.calibrated_length : d.length);
    }
  }
  std::ostringstream os;
  os << "# Simulated measurement of the offline network " << job.file << " (vlt network --simulate " << seed
     << "): the truth is its [targets] and station poses; the instruments' true parameters are drawn from\n"
     << "# their uncertainties, every reading carries the reading noise, references their u "
        "(docs/network.md).\n"
     << "# Adjust it with:  vlt network simulated_network.toml\n"
     << root << "\n";
  files.emplace_back("simulated_network.toml", os.str());
  return files;
}

}  // namespace vlt::network_outputs
