// Tasks in the Monte Carlo engine: each trial refits the drawn points with vlt/fits.h, the same
// definition the GUM engine linearises, so the fitting algorithm is itself propagated.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "results/internal.h"
#include "vlt/fits.h"

namespace vlt::internal {

std::string FormatNode(const Eigen::Vector3d& node) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.6g, %.6g, %.6g) m", node.x(), node.y(), node.z());
  return buffer;
}

McmTask MakeMcmTask(const TaskSpec& spec, const std::vector<int>& point_indices, const TaskUncertainty& gum) {
  McmTask task;
  task.name = spec.name;
  task.points = point_indices;
  std::span<const TaskOutput> outputs = TaskOutputs(spec.kind);
  for (const TaskOutput& o : outputs) {
    task.output_names.push_back(spec.name + "." + std::string(o.name));
    task.output_units.push_back(std::string(o.unit));
  }
  // Orientation of normals/directions: that of the fit to the estimates, so that no trial flips
  // the sign (vlt/fits.h FitOptions::orientation).
  FitOptions options;
  options.jacobian = false;
  auto component = [&](const char* name) {
    for (std::size_t q = 0; q < gum.quantities.size(); ++q) {
      if (gum.quantities[q] == name && q < static_cast<std::size_t>(gum.value.size())) return gum.value[q];
    }
    return 0.0;
  };
  if (spec.kind == TaskKind::kPlane || spec.kind == TaskKind::kCircle) {
    options.orientation = {component("normal_x"), component("normal_y"), component("normal_z")};
  } else if (spec.kind == TaskKind::kLine) {
    options.orientation = {component("direction_x"), component("direction_y"), component("direction_z")};
  }
  const TaskKind kind = spec.kind;
  const std::string where = "task '" + spec.name + "' (Monte Carlo trial)";
  const std::size_t n_out = outputs.size();
  task.evaluate = [kind, options, where, n_out](std::span<const Eigen::Vector3d> points, std::span<double> out) {
    Eigen::Matrix3Xd m(3, static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = points[i];
    FitResult fit = FitTask(kind, m, options, where);
    for (std::size_t q = 0; q < n_out; ++q) out[q] = fit.values[static_cast<Eigen::Index>(q)];
  };
  return task;
}

// The old definition, kept as the specification: the first of "%.6g" ... "%.17g" that reads back
// as v. Computed directly: the shortest round-trip representation (std::to_chars, Ryu) has d
// significant digits, no p < d round-trips, so the answer is "%.{max(6, d)}g" unless that rounding
// falls outside v's rounding interval (possible next to a power of two), then one more digit.
// std::to_chars(general, p) is specified as printf's %.pg ([charconv.to.chars]).
void AppendNum(std::string& out, double v) {
  char buffer[40];
  if (!std::isfinite(v)) {
    std::snprintf(buffer, sizeof buffer, "%g", v);
    out += buffer;
    return;
  }
  auto shortest = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific);
  int digits = 0;
  const char* e = buffer;
  for (; e < shortest.ptr && *e != 'e'; ++e) digits += (*e >= '0' && *e <= '9') ? 1 : 0;
  int exponent = 0;
  std::from_chars(e + 1 + (e[1] == '+' ? 1 : 0), shortest.ptr, exponent);
  // Away from a power of two the rounding interval is symmetric about v, and the closest
  // p-digit decimal (%.pg, p >= d) is then the shortest one padded with zeros, which %g strips:
  // "%.{max(6, d)}g" is the shortest digits laid out as %g lays them out (scientific when the
  // exponent is < -4 or >= the precision, else fixed). At a power of two (fraction bits all zero)
  // the interval below is half as wide, and subnormals are coarser: there %.pg is formatted and
  // read back for p = max(6, d) ... 17.
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  const bool power_of_two = (bits & ((std::uint64_t{1} << 52) - 1)) == 0;
  // Subnormals have fewer significant bits: their interval can hold several 6-digit decimals.
  const bool subnormal = (bits & (std::uint64_t{0x7ff} << 52)) == 0;
  const int precision = std::max(6, digits);
  if (!power_of_two && !subnormal) {
    if (exponent < -4 || exponent >= precision) {
      out.append(buffer, shortest.ptr);
    } else {
      auto fixed = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::fixed);
      out.append(buffer, fixed.ptr);
    }
    return;
  }
  for (int p = precision; p <= 17; ++p) {
    auto end = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, p).ptr;
    double back = 0.0;
    std::from_chars(buffer, end, back);
    if (back == v || p == 17) {
      out.append(buffer, end);
      return;
    }
  }
}

std::string Num(double v) {
  std::string out;
  AppendNum(out, v);
  return out;
}

std::string Sig(double v, int digits) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string SafeFileName(const std::string& name) {
  std::string out;
  for (char c : name) {
    bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
              c == '_' || c == '-';
    out += ok ? c : '_';
  }
  if (out.empty() || out == "." || out == "..") out = "job";
  return out;
}

}  // namespace vlt::internal
