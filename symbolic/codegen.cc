#include "codegen.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

namespace vlt::gen {
namespace {

using GiNaC::ex;

// ---------------------------------------------------------------------------------------------
// Ir: a hash-consed expression DAG with the operations the printer knows.
// Negative signs live only in kNeg nodes (coefficients and constants are kept positive), so a
// sum can print a negative term as a subtraction.
enum class Op { kNum, kSym, kAdd, kMul, kDiv, kNeg, kPow, kSqrt, kCall };

struct Node {
  Op op = Op::kNum;
  double value = 0.0;  // kNum: the value; kMul: the numeric coefficient (> 0)
  int n = 0;           // kPow: the integer exponent (>= 2)
  std::string name;    // kSym: input name; kCall: function name
  std::vector<int> args;
  std::uint64_t hash = 0;  // structural: from names, values and operand hashes only
};

std::uint64_t Mix(std::uint64_t h, std::uint64_t v) {
  // splitmix64 finaliser of the combined value: deterministic, platform independent.
  std::uint64_t z = h ^ (v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2));
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t HashString(const std::string& s) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ULL;
  return h;
}

std::uint64_t Bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

class Ir {
 public:
  const Node& operator[](int id) const { return nodes_[id]; }
  int size() const { return static_cast<int>(nodes_.size()); }

  int Num(double v) {
    if (v == 0.0) v = 0.0;  // no negative zero
    if (v < 0) return Neg(Num(-v));
    Node n;
    n.op = Op::kNum;
    n.value = v;
    return Intern(std::move(n));
  }
  int Sym(const std::string& name) {
    Node n;
    n.op = Op::kSym;
    n.name = name;
    return Intern(std::move(n));
  }
  bool IsNum(int id, double* v = nullptr) const {
    const Node& n = nodes_[id];
    if (n.op == Op::kNum) {
      if (v) *v = n.value;
      return true;
    }
    if (n.op == Op::kNeg && nodes_[n.args[0]].op == Op::kNum) {
      if (v) *v = -nodes_[n.args[0]].value;
      return true;
    }
    return false;
  }
  int Add(const std::vector<int>& terms) {
    double constant = 0.0;
    std::vector<int> rest;
    for (int t : terms) {
      double v;
      if (IsNum(t, &v)) {
        constant += v;
      } else {
        rest.push_back(t);
      }
    }
    if (constant != 0.0) rest.push_back(Num(constant));
    if (rest.empty()) return Num(0.0);
    if (rest.size() == 1) return rest[0];
    // Canonical sign: GiNaC may hold a sum as (a - b) or, negated elsewhere, as (b - a),
    // depending on its hash order (which varies between processes). Make the term with the
    // smallest sign-independent hash positive, pulling the sign out of the sum.
    int lead = rest[0];
    for (int t : rest) {
      if (AbsHash(t) < AbsHash(lead)) lead = t;
    }
    if (nodes_[lead].op == Op::kNeg) {
      std::vector<int> negated;
      for (int t : rest) negated.push_back(Neg(t));
      Node n;
      n.op = Op::kAdd;
      n.args = std::move(negated);
      return Neg(Intern(std::move(n)));
    }
    Node n;
    n.op = Op::kAdd;
    n.args = std::move(rest);
    return Intern(std::move(n));
  }
  int Mul(double coef, const std::vector<int>& factors) {
    std::vector<int> rest;
    for (int f : factors) {
      double v;
      if (IsNum(f, &v)) {
        coef *= v;
      } else if (nodes_[f].op == Op::kNeg) {
        coef = -coef;
        rest.push_back(nodes_[f].args[0]);
      } else {
        rest.push_back(f);
      }
    }
    if (coef == 0.0) return Num(0.0);
    if (rest.empty()) return Num(coef);
    const bool negative = coef < 0;
    coef = std::fabs(coef);
    int result;
    if (coef == 1.0 && rest.size() == 1) {
      result = rest[0];
    } else {
      Node n;
      n.op = Op::kMul;
      n.value = coef;
      n.args = std::move(rest);
      result = Intern(std::move(n));
    }
    return negative ? Neg(result) : result;
  }
  int Div(int num, int den) {
    double v;
    if (IsNum(num, &v) && v == 0.0) return Num(0.0);
    if (IsNum(den, &v) && v == 1.0) return num;
    if (nodes_[num].op == Op::kNeg) return Neg(Div(nodes_[num].args[0], den));
    if (nodes_[den].op == Op::kNeg) return Neg(Div(num, nodes_[den].args[0]));
    Node n;
    n.op = Op::kDiv;
    n.args = {num, den};
    return Intern(std::move(n));
  }
  int Neg(int a) {
    if (nodes_[a].op == Op::kNeg) return nodes_[a].args[0];
    if (nodes_[a].op == Op::kNum && nodes_[a].value == 0.0) return a;
    Node n;
    n.op = Op::kNeg;
    n.args = {a};
    return Intern(std::move(n));
  }
  int Pow(int a, int e) {
    if (e == 0) return Num(1.0);
    if (e == 1) return a;
    if (nodes_[a].op == Op::kNeg) {
      const int p = Pow(nodes_[a].args[0], e);
      return e % 2 ? Neg(p) : p;
    }
    Node n;
    n.op = Op::kPow;
    n.n = e;
    n.args = {a};
    return Intern(std::move(n));
  }
  int Sqrt(int a) {
    double v;
    if (IsNum(a, &v) && v >= 0) return Num(std::sqrt(v));  // IEEE sqrt is correctly rounded
    Node n;
    n.op = Op::kSqrt;
    n.args = {a};
    return Intern(std::move(n));
  }
  int Call(const std::string& name, const std::vector<int>& args) {
    // Canonical signs of odd and even functions (see Add).
    if (args.size() == 1 && nodes_[args[0]].op == Op::kNeg) {
      const int inner = nodes_[args[0]].args[0];
      if (name == "sin" || name == "tan" || name == "sinh" || name == "tanh" || name == "atan") {
        return Neg(Call(name, {inner}));
      }
      if (name == "cos" || name == "cosh") return Call(name, {inner});
    }
    Node n;
    n.op = Op::kCall;
    n.name = name;
    n.args = args;
    return Intern(std::move(n));
  }

 private:
  std::uint64_t AbsHash(int id) const {
    return nodes_[id].op == Op::kNeg ? nodes_[nodes_[id].args[0]].hash : nodes_[id].hash;
  }

  using Key = std::tuple<int, std::uint64_t, int, std::string, std::vector<int>>;

  int Intern(Node n) {
    std::vector<int> key_args = n.args;
    const bool commutative = n.op == Op::kAdd || n.op == Op::kMul;
    if (commutative) std::sort(key_args.begin(), key_args.end());
    Key key{static_cast<int>(n.op), Bits(n.value), n.n, n.name, key_args};
    auto found = intern_.find(key);
    if (found != intern_.end()) return found->second;
    std::uint64_t h = Mix(static_cast<std::uint64_t>(n.op) + 1, Bits(n.value));
    h = Mix(h, static_cast<std::uint64_t>(n.n));
    h = Mix(h, HashString(n.name));
    std::vector<std::uint64_t> child;
    for (int a : n.args) child.push_back(nodes_[a].hash);
    if (commutative) std::sort(child.begin(), child.end());
    for (auto c : child) h = Mix(h, c);
    n.hash = h;
    const int id = static_cast<int>(nodes_.size());
    nodes_.push_back(std::move(n));
    intern_.emplace(std::move(key), id);
    return id;
  }

  std::vector<Node> nodes_;
  std::map<Key, int> intern_;
};

// ---------------------------------------------------------------------------------------------
// GiNaC -> Ir

class Converter {
 public:
  Converter(Ir& ir, const Program& program, const std::vector<InputVar>& inputs) : ir_(ir) {
    for (const auto& [symbol, def] : program.assigns) defs_.emplace(symbol, def);
    for (const auto& in : inputs) inputs_.emplace(in.symbol, in.name);
  }

  int Convert(const ex& e) {
    auto found = memo_.find(e);
    if (found != memo_.end()) return found->second;
    const int id = ConvertNew(e);
    memo_.emplace(e, id);
    return id;
  }

 private:
  int ConvertNew(const ex& e) {
    using namespace GiNaC;
    if (is_a<numeric>(e)) {
      const numeric& v = ex_to<numeric>(e);
      if (!v.is_real()) throw std::runtime_error("complex number in a model expression");
      return ir_.Num(v.to_double());
    }
    if (is_a<constant>(e)) return ir_.Num(ex_to<numeric>(e.evalf()).to_double());
    if (is_a<symbol>(e)) {
      auto def = defs_.find(e);
      if (def != defs_.end()) return Convert(def->second);
      auto in = inputs_.find(e);
      if (in != inputs_.end()) return ir_.Sym(in->second);
      throw std::runtime_error("unknown symbol '" + ex_to<symbol>(e).get_name() + "' in a model expression");
    }
    if (is_a<add>(e)) {
      std::vector<int> terms;
      for (std::size_t i = 0; i < e.nops(); ++i) terms.push_back(Convert(e.op(i)));
      return ir_.Add(terms);
    }
    if (is_a<mul>(e)) {
      double coef = 1.0;
      std::vector<int> num, den;
      for (std::size_t i = 0; i < e.nops(); ++i) {
        const ex f = e.op(i);
        if (is_a<numeric>(f)) {
          coef *= ex_to<numeric>(f).to_double();
        } else if (is_a<power>(f) && is_a<numeric>(f.op(1)) && ex_to<numeric>(f.op(1)).is_negative()) {
          den.push_back(ConvertPower(f.op(0), -f.op(1)));
        } else {
          num.push_back(Convert(f));
        }
      }
      const int top = ir_.Mul(coef, num);
      return den.empty() ? top : ir_.Div(top, ir_.Mul(1.0, den));
    }
    if (is_a<power>(e)) return ConvertPower(e.op(0), e.op(1));
    if (is_a<function>(e)) {
      const std::string name = ex_to<function>(e).get_name();
      static const std::vector<std::string> kKnown = {"sin", "cos",  "tan",  "atan2", "exp",
                                                      "log", "atan", "sinh", "cosh",  "tanh"};
      if (std::find(kKnown.begin(), kKnown.end(), name) == kKnown.end()) {
        throw std::runtime_error("function '" + name + "' is not supported by vlt-gen");
      }
      std::vector<int> args;
      for (std::size_t i = 0; i < e.nops(); ++i) args.push_back(Convert(e.op(i)));
      return ir_.Call(name, args);
    }
    throw std::runtime_error("unsupported expression in a model");
  }

  int ConvertPower(const ex& base, const ex& exponent) {
    using namespace GiNaC;
    if (is_a<numeric>(exponent)) {
      const numeric& k = ex_to<numeric>(exponent);
      if (k.is_integer()) {
        const int n = k.to_int();
        const int p = ir_.Pow(Convert(base), std::abs(n));
        return n >= 0 ? p : ir_.Div(ir_.Num(1.0), p);
      }
      const numeric twice = k * 2;
      if (twice.is_integer()) {  // base^(m/2), m odd: sqrt once, then integer powers
        const int m = twice.to_int();
        const int b = Convert(base);
        const int s = ir_.Sqrt(b);
        const int whole = (std::abs(m) - 1) / 2;
        const int p = whole > 0 ? ir_.Mul(1.0, {ir_.Pow(b, whole), s}) : s;
        return m >= 0 ? p : ir_.Div(ir_.Num(1.0), p);
      }
    }
    return ir_.Call("pow", {Convert(base), Convert(exponent)});
  }

  Ir& ir_;
  std::map<ex, ex, GiNaC::ex_is_less> defs_;
  std::map<ex, std::string, GiNaC::ex_is_less> inputs_;
  std::map<ex, int, GiNaC::ex_is_less> memo_;
};

// ---------------------------------------------------------------------------------------------
// CSE and printing

}  // namespace

std::string Literal(double v) {
  char buf[64];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  std::string s(buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

namespace {

class Printer {
 public:
  Printer(const Ir& ir)
      : ir_(ir),
        uses_(ir.size(), 0),
        temp_(ir.size(), -1),
        is_temp_(ir.size(), false),
        seen_(ir.size(), false),
        pair_of_(ir.size(), -1) {}

  void CountUses(int id) {
    ++uses_[id];
    if (seen_[id]) return;
    seen_[id] = true;
    const Node& n = ir_[id];
    for (int a : n.args) CountUses(a);
    if (n.op == Op::kPow && !Leaf(n.args[0])) forced_.push_back(n.args[0]);
  }

  void DecideTemps() {
    for (int id = 0; id < ir_.size(); ++id) {
      if (!seen_[id] || Cheap(id)) continue;
      if (uses_[id] >= 2) is_temp_[id] = true;
    }
    for (int id : forced_) is_temp_[id] = true;
    PairSinCos();
  }

  // sin a and cos a of one argument a, both used: one SinCos(a, &s, &c) call computes both from
  // one range reduction (the SIMD lanes' and the GPU lane's SinCos; std::sin and std::cos for a
  // double, so its bits are those of the two calls). The pair's outputs are named variables, not
  // temporaries.
  void PairSinCos() {
    std::map<int, std::pair<int, int>> by_argument;  // a -> (sin a, cos a)
    for (int id = 0; id < ir_.size(); ++id) {
      const Node& n = ir_[id];
      if (!seen_[id] || n.op != Op::kCall || n.args.size() != 1) continue;
      if (n.name != "sin" && n.name != "cos") continue;
      auto [at, fresh] = by_argument.try_emplace(n.args[0], -1, -1);
      (n.name == "sin" ? at->second.first : at->second.second) = id;
    }
    for (const auto& [argument, calls] : by_argument) {
      if (calls.first < 0 || calls.second < 0) continue;
      pair_of_[calls.first] = pair_of_[calls.second] = static_cast<int>(pair_name_.size());
      is_temp_[calls.first] = is_temp_[calls.second] = false;
      pair_name_.push_back(-1);
    }
  }

  // Emits the temporaries needed by `id` (post-order, children in print order).
  void EmitTemps(int id, std::string& code) {
    if (Leaf(id) || done_.count(id)) return;
    done_.insert(id);
    for (int a : Children(id)) EmitTemps(a, code);
    if (pair_of_[id] >= 0) EmitSinCos(id, code);
    if (is_temp_[id]) {
      const std::string rhs = Print(id, 0, true);
      temp_[id] = next_temp_++;
      code += "  const Scalar _tmp" + std::to_string(temp_[id]) + " = " + rhs + ";\n";
    }
  }

  // The SinCos call of the pair of `id` (a sin or cos call), before the first use of either.
  void EmitSinCos(int id, std::string& code) {
    int& name = pair_name_[pair_of_[id]];
    if (name >= 0) return;
    name = next_pair_++;
    ++ops_;
    const std::string n = std::to_string(name);
    code += "  Scalar _sin" + n + ", _cos" + n + ";\n";
    code += "  SinCos(" + Print(ir_[id].args[0], 0, false) + ", &_sin" + n + ", &_cos" + n + ");\n";
  }

  std::string PrintRoot(int id) { return Print(id, 0, false); }
  int ops() const { return ops_; }
  const std::set<std::string>& used_inputs() const { return used_; }

 private:
  bool Leaf(int id) const { return ir_[id].op == Op::kNum || ir_[id].op == Op::kSym; }
  bool Cheap(int id) const { return Leaf(id) || (ir_[id].op == Op::kNeg && Leaf(ir_[id].args[0])); }

  // Operands in print order: sums and products sorted by structural hash (positive terms of a
  // sum first), everything else in its natural order.
  std::vector<int> Children(int id) const {
    const Node& n = ir_[id];
    std::vector<int> c = n.args;
    if (n.op == Op::kAdd || n.op == Op::kMul) {
      std::stable_sort(c.begin(), c.end(), [&](int a, int b) {
        const bool na = n.op == Op::kAdd && ir_[a].op == Op::kNeg;
        const bool nb = n.op == Op::kAdd && ir_[b].op == Op::kNeg;
        if (na != nb) return nb;
        return ir_[a].hash < ir_[b].hash;
      });
    }
    return c;
  }

  // Precedence: 1 sum, 2 product/quotient/negation, 3 atom (symbol, literal, temporary, call).
  int Precedence(int id, bool definition) const {
    if (!definition && temp_[id] >= 0) return 3;
    switch (ir_[id].op) {
      case Op::kAdd: return 1;
      case Op::kMul:
      case Op::kDiv:
      case Op::kNeg:
      case Op::kPow: return 2;
      default: return 3;
    }
  }

  std::string Wrap(int id, int min_precedence) {
    std::string s = Print(id, 0, false);
    if (Precedence(id, false) < min_precedence) s = "(" + s + ")";
    return s;
  }

  std::string Print(int id, int /*unused*/, bool definition) {
    if (!definition && temp_[id] >= 0) return "_tmp" + std::to_string(temp_[id]);
    const Node& n = ir_[id];
    if (pair_of_[id] >= 0) return (n.name == "sin" ? "_sin" : "_cos") + std::to_string(pair_name_[pair_of_[id]]);
    switch (n.op) {
      case Op::kNum: return Literal(n.value);
      case Op::kSym: used_.insert(n.name); return n.name;
      case Op::kAdd: {
        std::string s;
        bool first = true;
        for (int a : Children(id)) {
          if (ir_[a].op == Op::kNeg && temp_[a] < 0) {
            s += first ? "-" : " - ";
            if (first) ++ops_;  // unary minus
            s += Wrap(ir_[a].args[0], 2);
          } else {
            if (!first) s += " + ";
            s += Wrap(a, 2);
          }
          first = false;
        }
        ops_ += static_cast<int>(n.args.size()) - 1;
        return s;
      }
      case Op::kMul: {
        std::string s;
        int factors = 0;
        if (n.value != 1.0) {
          s = Literal(n.value);
          ++factors;
        }
        for (int a : Children(id)) {
          if (factors) s += "*";
          s += Wrap(a, 3);
          ++factors;
        }
        ops_ += factors - 1;
        return s;
      }
      case Op::kDiv: {
        ++ops_;
        return Wrap(n.args[0], 2) + "/" + Wrap(n.args[1], 3);
      }
      case Op::kNeg: {
        ++ops_;
        return "-" + Wrap(n.args[0], 3);
      }
      case Op::kPow: {
        const std::string base = Wrap(n.args[0], 3);
        std::string s = base;
        for (int i = 1; i < n.n; ++i) s += "*" + base;
        ops_ += n.n - 1;
        return s;
      }
      case Op::kSqrt: {
        ++ops_;
        return "sqrt(" + Print(n.args[0], 0, false) + ")";
      }
      case Op::kCall: {
        ++ops_;
        std::string s = n.name + "(";
        for (std::size_t i = 0; i < n.args.size(); ++i) {
          if (i) s += ", ";
          s += Print(n.args[i], 0, false);
        }
        return s + ")";
      }
    }
    return "";
  }

  const Ir& ir_;
  std::vector<int> uses_;
  std::vector<int> temp_;
  std::vector<bool> is_temp_;
  std::vector<bool> seen_;
  std::vector<int> forced_;
  std::set<int> done_;
  std::set<std::string> used_;
  std::vector<int> pair_of_;    // node -> its sin/cos pair, -1 if none
  std::vector<int> pair_name_;  // pair -> its number in _sinN/_cosN, -1 until emitted
  int next_temp_ = 0;
  int next_pair_ = 0;
  int ops_ = 0;
};

}  // namespace

FunctionBody EmitBody(const Program& program, const std::vector<InputVar>& inputs,
                      const std::vector<std::string>& lhs) {
  if (lhs.size() != program.roots.size()) throw std::logic_error("EmitBody: lhs/roots mismatch");
  Ir ir;
  Converter converter(ir, program, inputs);
  std::vector<int> roots;
  for (const ex& r : program.roots) roots.push_back(converter.Convert(r));
  Printer printer(ir);
  for (int r : roots) printer.CountUses(r);
  printer.DecideTemps();
  std::string temps;
  std::string assigns;
  for (std::size_t i = 0; i < roots.size(); ++i) {
    printer.EmitTemps(roots[i], temps);
    assigns += "  " + lhs[i] + " = " + printer.PrintRoot(roots[i]) + ";\n";
  }
  // EmitTemps interleaves with roots only through `temps`; all temporaries precede all
  // assignments, which is valid because a temporary depends on inputs and earlier ones only.
  FunctionBody body;
  for (const auto& in : inputs) {
    if (printer.used_inputs().count(in.name)) {
      body.code += "  const Scalar " + in.name + " = " + in.load + ";\n";
    }
  }
  body.code += temps + assigns;
  body.ops = printer.ops();
  return body;
}

}  // namespace vlt::gen
