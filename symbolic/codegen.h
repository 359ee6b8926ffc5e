// codegen.h — from a Program (GiNaC) to the body of a C++ function: one common-subexpression
// elimination pass over all roots at once, and a printer for templated Scalar code.
//
// GiNaC has no CSE, and the order of the operands of its sums and products depends on symbol
// serial numbers (creation order), so nothing here relies on GiNaC's ordering: expressions are
// converted into a hash-consed DAG (Ir) whose nodes carry a structural hash computed from names
// and values only; operands are printed and temporaries numbered in an order derived from those
// hashes, which makes the output byte-identical for the same spec in any process.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "graph.h"

namespace vlt::gen {

// An input of the generated function: its GiNaC symbol, the C++ local it is loaded into and
// the expression that loads it (e.g. "params[param::tmv]").
struct InputVar {
  GiNaC::ex symbol;
  std::string name;
  std::string load;
};

struct FunctionBody {
  std::string code;  // statements, indented by two spaces, ending in a newline
  int ops = 0;       // +, -, *, /, unary minus and calls of sqrt/sin/cos/atan2/... after CSE
};

// Shortest decimal that reads back as exactly v, always with a '.' or exponent ("2.0").
std::string Literal(double v);

// Emits `lhs[i] = root_i;` for every root of `program`, with shared subexpressions in
// temporaries _tmp0, _tmp1, ... and only the inputs that are used loaded into locals.
FunctionBody EmitBody(const Program& program, const std::vector<InputVar>& inputs,
                      const std::vector<std::string>& lhs);

}  // namespace vlt::gen
