#include "graph.h"

#include <algorithm>
#include <set>

namespace vlt::gen {

using GiNaC::ex;

namespace {

bool IsTrivial(const ex& e) { return GiNaC::is_a<GiNaC::numeric>(e) || GiNaC::is_a<GiNaC::symbol>(e); }

// Indices of the graph nodes that appear directly in e, ascending.
std::vector<int> NodeDeps(const Graph& graph, const ex& e) {
  std::set<int> deps;
  for (auto it = e.preorder_begin(); it != e.preorder_end(); ++it) {
    if (GiNaC::is_a<GiNaC::symbol>(*it)) {
      auto found = graph.index.find(*it);
      if (found != graph.index.end()) deps.insert(found->second);
    }
  }
  return {deps.begin(), deps.end()};
}

}  // namespace

ex Graph::Def(const ex& e) {
  if (IsTrivial(e)) return e;
  GiNaC::realsymbol v("_v" + std::to_string(nodes.size()));
  index[v] = static_cast<int>(nodes.size());
  nodes.push_back(v);
  defs.push_back(e);
  return v;
}

Program ForwardProgram(const Graph& graph) {
  Program p;
  for (std::size_t j = 0; j < graph.nodes.size(); ++j) p.assigns.emplace_back(graph.nodes[j], graph.defs[j]);
  p.roots = graph.outputs;
  return p;
}

Program JacobianProgram(const Graph& graph, const std::vector<ex>& wrt, const GiNaC::exmap& at,
                        bool with_values) {
  Program p;
  GiNaC::exmap subs = at;  // grows with nodes that become trivial
  int counter = 0;
  auto fresh = [&](const ex& e) -> ex {
    if (IsTrivial(e)) return e;
    GiNaC::realsymbol s("_d" + std::to_string(counter++));
    p.assigns.emplace_back(s, e);
    return s;
  };
  const std::size_t n = graph.nodes.size();
  std::vector<std::vector<ex>> d(n, std::vector<ex>(wrt.size(), ex(0)));

  // Derivative of an expression f (node definition or output) given the node derivatives d.
  auto differentiate = [&](const ex& f, std::vector<ex>& result) {
    const std::vector<int> deps = NodeDeps(graph, f);
    std::vector<ex> partial(deps.size());
    std::vector<bool> have(deps.size(), false);
    result.assign(wrt.size(), ex(0));
    for (std::size_t x = 0; x < wrt.size(); ++x) {
      ex sum = 0;
      if (f.has(wrt[x])) sum += f.diff(GiNaC::ex_to<GiNaC::symbol>(wrt[x])).subs(subs);
      for (std::size_t i = 0; i < deps.size(); ++i) {
        const ex& dk = d[deps[i]][x];
        if (dk.is_zero()) continue;
        if (!have[i]) {
          partial[i] = fresh(f.diff(GiNaC::ex_to<GiNaC::symbol>(graph.nodes[deps[i]])).subs(subs));
          have[i] = true;
        }
        sum += partial[i] * dk;
      }
      result[x] = sum;
    }
  };

  std::vector<ex> column;
  for (std::size_t j = 0; j < n; ++j) {
    const ex& f = graph.defs[j];
    const ex value = f.subs(subs);
    differentiate(f, column);
    if (IsTrivial(value)) {
      subs[graph.nodes[j]] = value;
    } else {
      p.assigns.emplace_back(graph.nodes[j], value);
    }
    for (std::size_t x = 0; x < wrt.size(); ++x) d[j][x] = fresh(column[x]);
  }
  if (with_values) {
    for (const ex& out : graph.outputs) p.roots.push_back(out.subs(subs));
  }
  std::vector<std::vector<ex>> jac(graph.outputs.size());
  for (std::size_t i = 0; i < graph.outputs.size(); ++i) differentiate(graph.outputs[i], jac[i]);
  for (std::size_t x = 0; x < wrt.size(); ++x) {
    for (std::size_t i = 0; i < graph.outputs.size(); ++i) p.roots.push_back(jac[i][x]);
  }
  return p;
}

Program HessianProgram(const Graph& graph, const std::vector<ex>& wrt) {
  const std::size_t n = wrt.size(), num_outputs = graph.outputs.size();
  // The first derivatives as a graph: roots[num_outputs * k + i] = d out_i / dx_k.
  const Program first = JacobianProgram(graph, wrt, {}, false);
  Graph jacobian;
  for (const auto& [symbol, def] : first.assigns) {
    jacobian.index[symbol] = static_cast<int>(jacobian.nodes.size());
    jacobian.nodes.push_back(symbol);
    jacobian.defs.push_back(def);
  }
  jacobian.outputs = first.roots;
  // Their derivatives: roots[n * num_outputs * l + num_outputs * k + i] = d2 out_i / dx_k dx_l.
  Program second = JacobianProgram(jacobian, wrt, {}, false);
  std::vector<ex> upper;
  for (std::size_t i = 0; i < num_outputs; ++i) {
    for (std::size_t l = 0; l < n; ++l) {
      for (std::size_t k = 0; k <= l; ++k)
        upper.push_back(second.roots[n * num_outputs * l + num_outputs * k + i]);
    }
  }
  second.roots = std::move(upper);
  return second;
}

}  // namespace vlt::gen
