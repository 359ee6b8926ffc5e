// points.npy ([output] arrays = true): every point's full detail as one NumPy structured array,
// SI units, the fields of points.jsonl and budget.csv side by side (docs/results.md "points.npy").
// A binary file rather than more text: a scan of 10^6 points is read by numpy.load(mmap_mode="r")
// without parsing, and no digit is rounded.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/npy.h"
#include "results/internal.h"

namespace vlt {
namespace {

using base_internal::NpyLayout;
using base_internal::NpyRecordWriter;

constexpr int kVerdictWidth = 16;  // "not validated", "inconclusive", "validated", "not run"

// The inputs of every point's budget in the engine's order: the three readings, the shared inputs,
// then the correlation row when the shared inputs are correlated (the same set for every point).
std::vector<std::string> BudgetInputs(const Results& r) {
  std::vector<std::string> inputs = {"range", "azimuth", "elevation"};
  for (const UncertainInput& in : r.shared_inputs) inputs.push_back(in.name);
  bool correlated = false;
  const std::size_t first[1] = {0};
  const std::vector<PointUncertainty> point = PointDetails(r, first, true, 1);
  for (const BudgetRow& b : point.front().budget) {
    correlated = correlated || b.group == "correlation";
  }
  if (correlated) inputs.push_back("correlations");
  return inputs;
}

int NameWidth(const Results& r) {
  std::size_t width = 1;
  for (const PointResult& p : r.points) width = std::max(width, p.input.name.size());
  return static_cast<int>(width);
}

NpyLayout PointLayout(const Results& r, const std::vector<std::string>& inputs, int name_width) {
  NpyLayout layout;
  layout.AddBytes("name", name_width);
  layout.AddByte("face");  // 0 front, 1 back
  layout.AddDoubles("readings", {3});
  layout.AddDoubles("u_readings", {3});
  if (r.mode == JobMode::kPlan) layout.AddDoubles("nominal", {3});
  layout.AddDoubles("estimate", {3});
  layout.AddDoubles("covariance", {3, 3});
  layout.AddDoubles("u", {3});
  layout.AddDoubles("k");
  layout.AddDoubles("U", {3});
  layout.AddDoubles("U_norm");
  layout.AddDoubles("ellipsoid_k");
  layout.AddDoubles("ellipsoid_semi_axes", {3});
  layout.AddDoubles("ellipsoid_directions", {3, 3});
  layout.AddDoubles("u_line_of_sight", {3});
  layout.AddDoubles("tracker_estimate", {3});
  layout.AddDoubles("tracker_covariance", {3, 3});
  layout.AddDoubles("second_order_variance", {3});
  layout.AddDoubles("second_order_ratio", {3});
  layout.AddBool("gum_reliable");
  layout.AddBool("second_order_decided");
  if (r.has_mcm) {
    layout.AddDoubles("mcm_mean", {3});
    layout.AddDoubles("mcm_covariance", {3, 3});
    layout.AddDoubles("mcm_coverage_factor");
    layout.AddDoubles("mcm_low", {3});
    layout.AddDoubles("mcm_high", {3});
    layout.AddDoubles("d_low", {3});
    layout.AddDoubles("d_high", {3});
    layout.AddDoubles("delta", {3});
    layout.AddDoubles("region_worst_ratio");
    layout.AddBytes("gum_vs_mcm", kVerdictWidth);
  }
  for (const std::string& input : inputs) {
    if (input != "correlations") layout.AddDoubles("sensitivity:" + input, {3});
    layout.AddDoubles("contribution:" + input, {3});
  }
  return layout;
}

void AppendMonteCarlo(const PointResult& p, NpyRecordWriter& record) {
  if (!p.has_mcm) {
    const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
    record.Vector(zero).Matrix(Eigen::Matrix3d::Zero()).Double(0.0);
    for (int i = 0; i < 5; ++i) record.Vector(zero);
    record.Double(0.0).Bytes("not run", kVerdictWidth);
    return;
  }
  const PointMcm& m = *p.monte_carlo;
  Eigen::Vector3d low, high, d_low, d_high, delta;
  for (int a = 0; a < 3; ++a) {
    low(a) = m.axes[a].symmetric.low;
    high(a) = m.axes[a].symmetric.high;
    d_low(a) = m.axis_validation[a].d_low;
    d_high(a) = m.axis_validation[a].d_high;
    delta(a) = m.axis_validation[a].delta;
  }
  record.Vector(m.mcm.mean).Matrix(m.mcm.covariance).Double(m.mcm.coverage_factor);
  record.Vector(low).Vector(high).Vector(d_low).Vector(d_high).Vector(delta);
  record.Double(m.region_validation.worst_ratio).Bytes(p.outcome, kVerdictWidth);
}

// One point's record, in PointLayout's order. `column` maps an input's name to its position in
// `inputs`; the budget's rows (sorted by share) are put back into that order. g: the point's full
// GUM result with its budget (PointDetails).
void AppendPoint(const Results& r, const PointResult& p, const PointUncertainty& g,
                 const std::unordered_map<std::string, std::size_t>& column, int name_width,
                 std::string& out) {
  std::vector<const BudgetRow*> rows(column.size(), nullptr);
  for (const BudgetRow& b : g.budget) {
    const auto c = column.find(b.input);
    if (c == column.end()) throw std::logic_error("points.npy: unexpected budget input '" + b.input + "'");
    rows[c->second] = &b;
  }
  for (std::size_t c = 0; c < rows.size(); ++c) {
    if (rows[c] == nullptr)
      throw std::logic_error("points.npy: point '" + p.input.name + "' has no budget row");
  }
  NpyRecordWriter record(out);
  record.Bytes(p.input.name, name_width).Byte(p.input.face == Face::kBack ? 1 : 0).Vector(g.readings);
  record.Vector(Eigen::Vector3d(rows[0]->u, rows[1]->u, rows[2]->u));
  if (r.mode == JobMode::kPlan) record.Vector(p.input.nominal);
  record.Vector(g.part)
      .Matrix(g.cov_part)
      .Vector(g.u_part)
      .Double(g.k)
      .Vector(g.U_part)
      .Double(g.U_part.norm());
  // Row j of ellipsoid_directions is the unit axis of semi_axes[j] (a column of the Eigen matrix).
  record.Double(g.ellipsoid.k).Vector(g.ellipsoid.semi_axes).Matrix(g.ellipsoid.directions.transpose());
  record.Vector(Eigen::Vector3d(g.los_part.u_radial, g.los_part.u_horizontal, g.los_part.u_vertical));
  record.Vector(g.tracker).Matrix(g.cov_tracker);
  record.Vector(g.second_order_variance).Vector(g.second_order_ratio).Bool(g.gum_reliable);
  record.Bool(g.second_order_decided);
  if (r.has_mcm) AppendMonteCarlo(p, record);
  for (const BudgetRow* b : rows) {
    if (b->group != "correlation") record.Vector(b->sensitivity);
    record.Vector(b->contribution);
  }
}

}  // namespace

void WritePointsNpy(const Results& r, OutputText& out) {
  const std::vector<std::string> inputs = BudgetInputs(r);
  std::unordered_map<std::string, std::size_t> column;
  for (std::size_t i = 0; i < inputs.size(); ++i) column[inputs[i]] = i;
  const int name_width = NameWidth(r);
  const NpyLayout layout = PointLayout(r, inputs, name_width);
  out.Write(layout.Header(r.points.size()));
  results_internal::WritePointDetails(
      r, out, true, [&](std::size_t first, std::span<const PointUncertainty> points, std::string& bytes) {
        bytes.reserve(bytes.size() + points.size() * layout.record_size());
        for (std::size_t i = 0; i < points.size(); ++i) {
          AppendPoint(r, r.points[first + i], points[i], column, name_width, bytes);
        }
      });
}

}  // namespace vlt
