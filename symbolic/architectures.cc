#include "architectures.h"

#include <array>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace vlt::gen {
namespace {

using GiNaC::ex;
using V3 = std::array<ex, 3>;

const std::vector<KnownParam> kReflectorParams = {
    {"srr", "m", "length"}, {"srh", "m", "length"}, {"srv", "m", "length"}, {"sdh", "rad", "angle"}};

const std::vector<KnownParam>& MirrorParams() {
  static const std::vector<KnownParam> kParams = [] {
    std::vector<KnownParam> p = {
        {"a0", "rad", "angle"},  {"eac", "rad", "angle"}, {"eas", "rad", "angle"}, {"e0", "rad", "angle"},
        {"eec", "rad", "angle"}, {"ees", "rad", "angle"}, {"thv", "m", "length"},  {"rhv", "rad", "angle"},
        {"rmv", "rad", "angle"}, {"tmv", "m", "length"},  {"tbw", "m", "length"},  {"tbv", "m", "length"},
        {"rbh", "rad", "angle"}, {"rbv", "rad", "angle"}, {"R0", "m", "length"},   {"mu", "1", "ratio"}};
    p.insert(p.end(), kReflectorParams.begin(), kReflectorParams.end());
    return p;
  }();
  return kParams;
}

const std::vector<KnownParam>& HeadParams() {
  static const std::vector<KnownParam> kParams = [] {
    std::vector<KnownParam> p = {
        {"lam", "m", "length"},    {"mu", "1", "ratio"},    {"ex", "m", "length"},
        {"by", "m", "length"},     {"bz", "m", "length"},   {"alpha", "rad", "angle"},
        {"gamma", "rad", "angle"}, {"ae0", "rad", "angle"}, {"aa1", "rad", "angle"},
        {"ba1", "rad", "angle"},   {"aa2", "rad", "angle"}, {"ba2", "rad", "angle"},
        {"ae1", "rad", "angle"},   {"be1", "rad", "angle"}, {"ae2", "rad", "angle"},
        {"be2", "rad", "angle"}};
    p.insert(p.end(), kReflectorParams.begin(), kReflectorParams.end());
    return p;
  }();
  return kParams;
}

// Rotations of a column vector (right-handed, angle counter-clockwise about the axis).
V3 RotX(const ex& c, const ex& s, const V3& v) { return {v[0], c * v[1] - s * v[2], s * v[1] + c * v[2]}; }
V3 RotY(const ex& c, const ex& s, const V3& v) { return {c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]}; }
V3 RotZ(const ex& c, const ex& s, const V3& v) { return {c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]}; }
ex Dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 Add(const V3& a, const V3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 Sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 Scale(const ex& s, const V3& a) { return {s * a[0], s * a[1], s * a[2]}; }
V3 DefV(Graph& g, const V3& v) { return {g.Def(v[0]), g.Def(v[1]), g.Def(v[2])}; }

// Parameter lookup: the active symbol, or 0 for a parameter the spec leaves out.
class ParamSet {
 public:
  explicit ParamSet(std::map<std::string, ex> active) : active_(std::move(active)) {}
  ex operator()(const std::string& name) const {
    auto it = active_.find(name);
    return it == active_.end() ? ex(0) : it->second;
  }

 private:
  std::map<std::string, ex> active_;
};

// The reflector (SMR), shared by all tracker architectures. The beam leaves point O along the
// unit direction dr and is pointed at the reflector; l is the length from O to the vertex.
// Pointing frame: e_h = normalize(e_z x dr) (horizontal, toward increasing azimuth),
// e_v = dr x e_h (toward increasing elevation).
//  - Dihedral angle error sdh (all three equal, hollow cube corner): the return beam deviates
//    by beta = (4*sqrt(6)/3)*sdh; the tracker nulls its PSD by pointing beta/2 off, modelled
//    as a rotation of the line of sight by psi = beta/2 toward e_v (stated simplification:
//    the deviation direction depends on the SMR clocking, fixed here along e_v).
//  - Vertex offsets: the vertex V lies srr farther than the sphere centre C along dr, srh
//    along e_h and srv along e_v:  C = V - srr*dr - srh*e_h - srv*e_v.
V3 Reflector(Graph& g, const ParamSet& p, const V3& o, const V3& dr, const ex& l) {
  const ex srr = p("srr"), srh = p("srh"), srv = p("srv"), sdh = p("sdh");
  V3 c = o;
  V3 d = dr;
  if (!srh.is_zero() || !srv.is_zero() || !sdh.is_zero()) {
    const ex h = g.Def(GiNaC::sqrt(dr[0] * dr[0] + dr[1] * dr[1]));
    const V3 eh = DefV(g, {-dr[1] / h, dr[0] / h, 0});
    // dr x e_h, written with dr0^2 + dr1^2 = h^2 (exact for a unit dr).
    const V3 ev = DefV(g, {-dr[2] * dr[0] / h, -dr[2] * dr[1] / h, h});
    if (!sdh.is_zero()) {
      const ex psi = g.Def(2 * GiNaC::sqrt(ex(6)) / 3 * sdh);
      const ex cp = g.Def(GiNaC::cos(psi)), sp = g.Def(GiNaC::sin(psi));
      d = DefV(g, Add(Scale(cp, dr), Scale(sp, ev)));
    }
    c = Sub(Sub(Add(c, Scale(l, d)), Scale(srh, eh)), Scale(srv, ev));
  } else {
    c = Add(c, Scale(l, d));
  }
  return Sub(c, Scale(srr, dr));
}

// Beam-steering-mirror tracker (paper Fig. 1/5, eq. 1-9 plus Table 1 errors). docs/models.md.
void BuildMirror(BuiltModel& m, const ParamSet& p) {
  Graph& g = m.graph;
  const ex range = m.readings[0], az = m.readings[1], el = m.readings[2];
  // Encoders: the first-harmonic error function is the parametrisation of eccentricity.
  const ex a = g.Def(az + p("a0") + p("eac") * GiNaC::cos(az) + p("eas") * GiNaC::sin(az));
  const ex tau_r = el / 2;  // beam elevation = 2 x mirror angle
  const ex tau = g.Def(tau_r + p("e0") + p("eec") * GiNaC::cos(tau_r) + p("ees") * GiNaC::sin(tau_r));
  const ex ca = g.Def(GiNaC::cos(a)), sa = g.Def(GiNaC::sin(a));
  const ex ct = g.Def(GiNaC::cos(tau)), st = g.Def(GiNaC::sin(tau));
  const ex rhv = p("rhv"), rmv = p("rmv");
  const ex ch = g.Def(GiNaC::cos(rhv)), sh = g.Def(GiNaC::sin(rhv));
  // Transit axis through q = Rz(A) (thv, 0, 0).
  const V3 q = {ca * p("thv"), sa * p("thv"), 0};
  // Mirror normal in the transit frame, then n = Rz(A) Rx(rhv) Ry(-tau) n0.
  const ex cm = GiNaC::cos(rmv), sm = GiNaC::sin(rmv);
  const ex r2 = GiNaC::sqrt(ex(2)) / 2;
  const V3 n0 = {cm * r2, sm, -cm * r2};
  const V3 nt = DefV(g, RotY(ct, -st, n0));
  const V3 n = DefV(g, RotZ(ca, sa, RotX(ch, sh, nt)));
  // Incident beam through b0 = (tbw, tbv, 0), direction Ry(rbh) Rx(rbv) e_z.
  const ex rbh = p("rbh"), rbv = p("rbv");
  const V3 ei =
      DefV(g, {GiNaC::sin(rbh) * GiNaC::cos(rbv), -GiNaC::sin(rbv), GiNaC::cos(rbh) * GiNaC::cos(rbv)});
  const V3 b0 = {p("tbw"), p("tbv"), 0};
  // Line-plane intersection with the mirror plane {X : n.(X - q) = tmv}.
  const ex nei = g.Def(Dot(n, ei));
  const ex tm = g.Def((p("tmv") - Dot(n, Sub(b0, q))) / nei);
  const V3 mhit = DefV(g, Add(b0, Scale(tm, ei)));
  // Reflection d = ei - 2 (ei.n) n.
  const V3 dr = DefV(g, Sub(ei, Scale(2 * nei, n)));
  // Ranging: g = (1+mu) rho + R0 counted from z = 0 along the beam; the mirror takes tm of it.
  const ex l = g.Def((1 + p("mu")) * range + p("R0") - tm);
  const V3 c = Reflector(g, p, mhit, dr, l);
  m.graph.outputs = {c[0], c[1], c[2]};
}

// Laser-in-head tracker, NPL chain (reference README section 2; Hughes et al. 2011).
void BuildHead(BuiltModel& m, const ParamSet& p) {
  Graph& g = m.graph;
  const ex range = m.readings[0], hz = m.readings[1], el = m.readings[2];
  const ex dp = g.Def((1 + p("mu")) * range + p("lam"));
  const ex h = g.Def(hz + p("aa1") * GiNaC::cos(hz) + p("ba1") * GiNaC::sin(hz) +
                     p("aa2") * GiNaC::cos(2 * hz) + p("ba2") * GiNaC::sin(2 * hz));
  const ex z = GiNaC::Pi / 2 - el;
  const ex zp = g.Def(z + p("ae0") + p("ae1") * GiNaC::cos(z) + p("be1") * GiNaC::sin(z) +
                      p("ae2") * GiNaC::cos(2 * z) + p("be2") * GiNaC::sin(2 * z));
  const ex ch = g.Def(GiNaC::cos(h)), sh = g.Def(GiNaC::sin(h));
  // Ry(Z' - pi/2): cos = sin Z', sin = -cos Z'.
  const ex cy = g.Def(GiNaC::sin(zp)), sy = g.Def(-GiNaC::cos(zp));
  const ex alpha = p("alpha"), gamma = p("gamma");
  const ex ca = g.Def(GiNaC::cos(alpha)), sa = g.Def(GiNaC::sin(alpha));
  // M v = Rz(H') Rx(alpha) Ry(Z' - pi/2) Rx(-alpha) v
  auto rot = [&](const V3& v) { return RotZ(ch, sh, RotX(ca, sa, RotY(cy, sy, RotX(ca, -sa, v)))); };
  const ex ex_ = p("ex");
  const V3 b = DefV(g, Add(RotZ(ch, sh, {ex_, 0, 0}), rot({-ex_, p("by"), p("bz")})));
  const V3 n = DefV(g, rot({GiNaC::cos(gamma), GiNaC::sin(gamma), 0}));
  const V3 c = Reflector(g, p, b, n, dp);
  m.graph.outputs = {c[0], c[1], c[2]};
}

QuantitySpec Named(const char* name, const char* unit, const char* quantity, const char* description) {
  QuantitySpec q;
  q.name = name;
  q.unit = unit;
  q.quantity = quantity;
  q.description = description;
  return q;
}

std::vector<QuantitySpec> TrackerReadings() {
  return {Named("range", "m", "length",
                "Range reading rho_r: distance the tracker reports to the reflector centre"),
          Named("azimuth", "rad", "angle", "Azimuth reading A_r, counter-clockwise from +x seen from above"),
          Named("elevation", "rad", "angle", "Elevation reading E_r from the horizontal plane, positive up")};
}

std::vector<QuantitySpec> TrackerOutputs() {
  return {Named("x", "m", "length", "True reflector-centre x coordinate in the tracker frame"),
          Named("y", "m", "length", "True reflector-centre y coordinate in the tracker frame"),
          Named("z", "m", "length", "True reflector-centre z coordinate in the tracker frame (up)")};
}

// What vlt-gen can emit, checked where the spec says it (SpecError "<where>: <problem>"), not
// left to the printer's internal errors or to the compiler: real numbers within a double's range
// (1e400 printed as inf, which no compiler takes), integer powers up to kMaxIntegerPower (x^n is
// printed as n - 1 products: a^1000000000 took 8 GB), the functions the printer knows. The tree is
// walked with a stack of its own (its depth is bounded by the text's, CheckExpressionText).
void CheckExpression(const GiNaC::ex& expression, const std::string& where) {
  using namespace GiNaC;
  static const std::set<std::string> kFunctions = {"sin", "cos", "tan", "atan2", "exp",
                                                   "log", "atan", "sinh", "cosh", "tanh"};
  std::vector<ex> stack = {expression};
  while (!stack.empty()) {
    const ex e = stack.back();
    stack.pop_back();
    if (is_a<numeric>(e)) {
      const numeric& v = ex_to<numeric>(e);
      if (!v.is_real()) throw SpecError(where + ": a complex number (the square root of a negative number, or I)");
      if (!std::isfinite(v.to_double()) || (!v.is_zero() && v.to_double() == 0.0)) {
        throw SpecError(where + ": a number beyond the range of a double (about 1e-308 to 1e308)");
      }
    } else if (is_a<power>(e) && is_a<numeric>(e.op(1)) && ex_to<numeric>(e.op(1)).is_integer() &&
               abs(ex_to<numeric>(e.op(1))) > kMaxIntegerPower) {
      throw SpecError(where + ": an integer power above " + std::to_string(kMaxIntegerPower) +
                      " (each is printed as products; write exp(n*log(x)) for x > 0)");
    } else if (is_a<function>(e) && !kFunctions.count(ex_to<function>(e).get_name())) {
      throw SpecError(where + ": function '" + ex_to<function>(e).get_name() +
                      "' is not supported (sin, cos, tan, atan, atan2, sinh, cosh, tanh, exp, log, sqrt and ^)");
    }
    for (std::size_t i = 0; i < e.nops(); ++i) stack.push_back(e.op(i));
  }
}

}  // namespace

const std::vector<KnownParam>& ArchitectureParams(const std::string& architecture) {
  static const std::vector<KnownParam> kNone;
  if (architecture == "mirror") return MirrorParams();
  if (architecture == "head") return HeadParams();
  return kNone;
}

BuiltModel BuildModel(const ModelSpec& spec) {
  BuiltModel m;
  std::map<std::string, ex> active;
  // Symbols are created in spec order: readings, then parameters/inputs (determinism does not
  // depend on it, see codegen.h, but it keeps GiNaC's own work reproducible).
  if (spec.kind == "tracker") {
    m.reading_info = TrackerReadings();
    for (const auto& r : m.reading_info) m.readings.push_back(GiNaC::realsymbol(r.name));
    const auto& known = ArchitectureParams(spec.architecture);
    for (std::size_t i = 0; i < spec.params.size(); ++i) {
      const QuantitySpec& q = spec.params[i];
      const std::string where = spec.path + ": parameter[" + std::to_string(i) + "](" + q.name + ")";
      const KnownParam* k = nullptr;
      for (const auto& kp : known) {
        if (q.name == kp.name) k = &kp;
      }
      if (!k) {
        std::string list;
        for (const auto& kp : known) list += (list.empty() ? "" : ", ") + std::string(kp.name);
        throw SpecError(where + ".name: unknown parameter of architecture '" + spec.architecture +
                        "' (known: " + list + ")");
      }
      if (q.unit != k->unit) {
        throw SpecError(where + ".unit: must be \"" + std::string(k->unit) + "\", not \"" + q.unit + "\"");
      }
      if (q.quantity != k->quantity) {
        throw SpecError(where + ".quantity: must be \"" + std::string(k->quantity) + "\", not \"" +
                        q.quantity + "\"");
      }
      GiNaC::realsymbol s(q.name);
      m.params.push_back(s);
      active[q.name] = s;
    }
    const ParamSet p(active);
    if (spec.architecture == "mirror") {
      BuildMirror(m, p);
    } else {
      BuildHead(m, p);
    }
    m.output_info = TrackerOutputs();
    return m;
  }
  // Custom model: outputs are GiNaC expressions over realsymbols of the inputs.
  GiNaC::symtab table;
  for (const auto& q : spec.params) {
    GiNaC::realsymbol s(q.name);
    m.params.push_back(s);
    table[q.name] = s;
  }
  table["Pi"] = GiNaC::Pi;
  for (std::size_t i = 0; i < spec.outputs.size(); ++i) {
    const QuantitySpec& o = spec.outputs[i];
    const std::string where = spec.path + ": output[" + std::to_string(i) + "](" + o.name + ")";
    GiNaC::parser reader(table, true);
    try {
      m.graph.outputs.push_back(reader(o.expression));
    } catch (const std::exception& e) {
      std::string msg = e.what();
      for (char& c : msg) {
        if (c == '\n') c = ' ';
      }
      throw SpecError(where + ".expression: cannot parse '" + o.expression + "': " + msg);
    }
    CheckExpression(m.graph.outputs.back(), where + ".expression");
    m.output_info.push_back(o);
  }
  return m;
}

}  // namespace vlt::gen
