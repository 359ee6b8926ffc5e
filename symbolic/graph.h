// graph.h — a model as a computational graph of GiNaC expressions, and its derivatives.
//
// Fully expanding a ray trace makes GiNaC's differentiation re-derive shared subexpressions
// many times over. Instead a model is a list of intermediate quantities v_j := f_j(inputs,
// v_<j), each a realsymbol, and the outputs are expressions in inputs and intermediates.
// Derivatives follow the chain rule node by node (forward mode):
//   dv_j/dx = df_j/dx + sum_k df_j/dv_k * dv_k/dx
// where every partial df_j/dx, df_j/dv_k is computed exactly by GiNaC::diff on the small local
// expression f_j. The result is a Program: assignments (symbol := expression) plus root
// expressions, which codegen inlines into one DAG and runs one CSE pass over.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <ginac/ginac.h>

namespace vlt::gen {

struct Graph {
  std::vector<GiNaC::ex> nodes;                       // realsymbols v_j
  std::vector<GiNaC::ex> defs;                        // f_j
  std::map<GiNaC::ex, int, GiNaC::ex_is_less> index;  // v_j -> j
  std::vector<GiNaC::ex> outputs;

  // Adds v := e and returns v; numbers and symbols are returned unchanged (nothing to share).
  GiNaC::ex Def(const GiNaC::ex& e);
};

// Assignments in dependency order and the expressions to evaluate (the function's outputs).
struct Program {
  std::vector<std::pair<GiNaC::ex, GiNaC::ex>> assigns;
  std::vector<GiNaC::ex> roots;
};

// The outputs alone.
Program ForwardProgram(const Graph& graph);

// Values (if `with_values`) then the Jacobian columns of the outputs with respect to each of
// `wrt` (column-major: for each x in wrt, every output). `at` is substituted into every node
// definition and every partial derivative AFTER differentiation (e.g. all parameters -> 0 for
// the nominal Jacobians); GiNaC then simplifies, and nodes that become numbers or symbols are
// propagated into later nodes.
Program JacobianProgram(const Graph& graph, const std::vector<GiNaC::ex>& wrt, const GiNaC::exmap& at,
                        bool with_values);

// The second derivatives d2 out_i / dx_k dx_l for k <= l (both in `wrt`), forward mode over
// forward mode: the Jacobian program is itself a graph (its assignments are the nodes, its roots
// the outputs), and JacobianProgram differentiates it once more. Every derivative is exact
// (GiNaC::diff of small local expressions); no substitution. Roots: for each output i, for each
// l, for k = 0..l: d2 out_i / dx_k dx_l (the upper triangle of output i's Hessian, column by
// column).
Program HessianProgram(const Graph& graph, const std::vector<GiNaC::ex>& wrt);

}  // namespace vlt::gen
