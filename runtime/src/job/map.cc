// The grid of an uncertainty map (`vlt map`, [map] in a job): parsing and node generation.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt {
namespace {

std::vector<std::string> SplitCommas(std::string_view text) {
  std::vector<std::string> parts;
  std::string current;
  for (char c : text) {
    if (c == ',') {
      parts.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  parts.push_back(current);
  return parts;
}

std::string Metres(double v) {
  std::ostringstream os;
  os << FormatQuantity(v, Dimension::kLength, "m", 6);
  return os.str();
}

double ParseStep(std::string_view step, std::string_view where) {
  double s = ParseQuantity(step, Dimension::kLength, std::string(where) + ": step");
  if (!(s > 0.0)) throw InputError(std::string(where) + ": step: must be positive");
  return s;
}

// Ranges [min, max] of the free axes; at most 1e6 nodes in all.
void FillRanges(MapSettings& map, const std::vector<int>& axes, std::string_view text, std::string_view what,
                std::string_view where) {
  std::vector<std::string> parts = SplitCommas(text);
  const char* axis_names = "xyz";
  std::string w = std::string(where) + ": " + std::string(what);
  if (parts.size() != 2 * axes.size()) {
    throw InputError(w + ": expected " + std::to_string(2 * axes.size()) + " comma-separated values (" +
                     (axes.size() == 2
                          ? std::string(1, axis_names[axes[0]]) + "min," + axis_names[axes[0]] + "max," +
                                axis_names[axes[1]] + "min," + axis_names[axes[1]] + "max"
                          : std::string("xmin,xmax,ymin,ymax,zmin,zmax")) +
                     "), got '" + std::string(text) + "'");
  }
  for (std::size_t k = 0; k < axes.size(); ++k) {
    int a = axes[k];
    map.min[a] = ParseQuantity(parts[2 * k], Dimension::kLength, w);
    map.max[a] = ParseQuantity(parts[2 * k + 1], Dimension::kLength, w);
    // The cap on every value (|x| <= 1e12 m): beyond it a node's snap to 1 nm (Node) overflows.
    CheckValueMagnitude(map.min[a], w);
    CheckValueMagnitude(map.max[a], w);
    if (!(map.max[a] >= map.min[a])) {
      throw InputError(w + ": " + std::string(1, axis_names[a]) + "max < " + std::string(1, axis_names[a]) +
                       "min");
    }
  }
  // Count in double before any conversion to int: a span of 3e9 m at 1 m steps is 3e9 nodes,
  // beyond int (the cast would be undefined behaviour).
  double nodes = 1.0;
  for (int a = 0; a < 3; ++a) nodes *= std::floor((map.max[a] - map.min[a]) / map.step + 1e-9) + 1.0;
  if (!(nodes <= kMaxMapNodes)) {
    char count[32];
    std::snprintf(count, sizeof count, "%.3g", nodes);
    throw InputError(std::string(where) + ": step: the grid has " + count + " nodes, more than " +
                     std::to_string(static_cast<long long>(kMaxMapNodes)) +
                     "; use a larger step or a smaller extent");
  }
}

}  // namespace

Eigen::Vector3i MapSettings::counts() const {
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) {
    double span = max[a] - min[a];
    // floor with a tolerance so that 0..4 m at 0.25 m gives 17 nodes despite rounding.
    n[a] = static_cast<int>(std::floor(span / step + 1e-9)) + 1;
  }
  return n;
}

double MapSettings::Node(double from, int index) const {
  // min + i step lands beside the decimal the grid means (-0.6 + 5 * 0.1 = -0.09999999999999998,
  // which a box edge at y = -0.1 then contains): snapped to 1 nm, it is the double of "-0.1".
  return std::round((from + index * step) * 1e9) / 1e9 + 0.0;  // + 0.0: no -0
}

std::vector<Eigen::Vector3d> MapSettings::Nodes() const {
  Eigen::Vector3i n = counts();
  std::vector<Eigen::Vector3d> nodes;
  nodes.reserve(static_cast<std::size_t>(n[0]) * n[1] * n[2]);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        nodes.emplace_back(Node(min[0], i), Node(min[1], j), Node(min[2], k));
  return nodes;
}

MapSettings ParseMapPlane(std::string_view plane, std::string_view extent, std::string_view step,
                          std::string_view where) {
  MapSettings map;
  map.kind = MapSettings::Kind::kPlane;
  std::string w = std::string(where) + ": plane";
  std::size_t eq = plane.find('=');
  std::string axis(plane.substr(0, eq == std::string_view::npos ? 0 : eq));
  axis.erase(0, axis.find_first_not_of(" \t"));
  axis.erase(axis.find_last_not_of(" \t") + 1);
  if (eq == std::string_view::npos || (axis != "x" && axis != "y" && axis != "z")) {
    throw InputError(w + ": expected x=<value>, y=<value> or z=<value>, got '" + std::string(plane) + "'");
  }
  map.fixed_axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
  map.level = ParseQuantity(plane.substr(eq + 1), Dimension::kLength, w);
  CheckValueMagnitude(map.level, w);
  map.step = ParseStep(step, where);
  std::vector<int> free_axes;
  for (int a = 0; a < 3; ++a)
    if (a != map.fixed_axis) free_axes.push_back(a);
  map.min[map.fixed_axis] = map.max[map.fixed_axis] = map.level;
  FillRanges(map, free_axes, extent, "extent", where);
  const char* names = "xyz";
  char a0 = names[free_axes[0]], a1 = names[free_axes[1]];
  map.description = "plane " + axis + " = " + Metres(map.level) + ", " + a0 + " " +
                    Metres(map.min[free_axes[0]]) + " .. " + Metres(map.max[free_axes[0]]) + ", " + a1 + " " +
                    Metres(map.min[free_axes[1]]) + " .. " + Metres(map.max[free_axes[1]]) + ", step " +
                    Metres(map.step);
  return map;
}

MapSettings ParseMapBox(std::string_view box, std::string_view step, std::string_view where) {
  MapSettings map;
  map.kind = MapSettings::Kind::kBox;
  map.step = ParseStep(step, where);
  FillRanges(map, {0, 1, 2}, box, "box", where);
  map.description = "box x " + Metres(map.min[0]) + " .. " + Metres(map.max[0]) + ", y " +
                    Metres(map.min[1]) + " .. " + Metres(map.max[1]) + ", z " + Metres(map.min[2]) + " .. " +
                    Metres(map.max[2]) + ", step " + Metres(map.step);
  return map;
}

}  // namespace vlt
