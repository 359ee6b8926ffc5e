#include "spec.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>

#include <toml++/toml.h>

namespace vlt::gen {
namespace {

const std::set<std::string>& ReservedNames() {
  // Names the generated code itself uses (function arguments, locals, functions it calls,
  // C++ keywords that a metrologist might pick).
  static const std::set<std::string> kReserved = {"Scalar",
                                                  "readings",
                                                  "params",
                                                  "out",
                                                  "column",
                                                  "d_out_d_readings",
                                                  "d_out_d_params",
                                                  "param",
                                                  "range",
                                                  "azimuth",
                                                  "elevation",
                                                  "sin",
                                                  "cos",
                                                  "tan",
                                                  "atan2",
                                                  "sqrt",
                                                  "exp",
                                                  "log",
                                                  "pow",
                                                  "abs",
                                                  "std",
                                                  "vlt",
                                                  "auto",
                                                  "bool",
                                                  "break",
                                                  "case",
                                                  "char",
                                                  "class",
                                                  "const",
                                                  "default",
                                                  "delete",
                                                  "do",
                                                  "double",
                                                  "else",
                                                  "enum",
                                                  "extern",
                                                  "float",
                                                  "for",
                                                  "friend",
                                                  "goto",
                                                  "if",
                                                  "inline",
                                                  "int",
                                                  "long",
                                                  "new",
                                                  "operator",
                                                  "private",
                                                  "protected",
                                                  "public",
                                                  "register",
                                                  "return",
                                                  "short",
                                                  "signed",
                                                  "sizeof",
                                                  "static",
                                                  "struct",
                                                  "switch",
                                                  "template",
                                                  "this",
                                                  "throw",
                                                  "try",
                                                  "typedef",
                                                  "typename",
                                                  "union",
                                                  "unsigned",
                                                  "using",
                                                  "virtual",
                                                  "void",
                                                  "volatile",
                                                  "while",
                                                  "and",
                                                  "or",
                                                  "not",
                                                  "xor",
                                                  "Pi",
                                                  "I",
                                                  "Euler",
                                                  "Catalan",
                                                  "kNumReadings",
                                                  "kNumParams",
                                                  "kNumOutputs",
                                                  // The rest of C++20's keywords and alternative tokens.
                                                  "alignas", "alignof", "asm", "catch", "char8_t", "char16_t",
                                                  "char32_t", "co_await", "co_return", "co_yield", "concept",
                                                  "consteval", "constexpr", "constinit", "const_cast", "continue",
                                                  "decltype", "dynamic_cast", "explicit", "export", "false",
                                                  "mutable", "namespace", "noexcept", "nullptr", "reinterpret_cast",
                                                  "requires", "static_assert", "static_cast", "thread_local", "true",
                                                  "typeid", "wchar_t", "and_eq", "bitand", "bitor", "compl",
                                                  "not_eq", "or_eq", "xor_eq", "final", "override", "import",
                                                  "module",
                                                  // Names of the generated code (the kernels, their helpers
                                                  // and arguments).
                                                  "kNumInputs", "SinCos", "Forward", "ForwardJacobians",
                                                  "NominalJacobians", "Hessians", "hessians", "ForwardLanes",
                                                  "ForwardBatch", "NominalJacobiansBatch", "Sensitivity", "Lanes",
                                                  "model", "Index", "sine", "cosine", "stride", "params_stride"};
  return kReserved;
}

// The macros the headers of the generated code define with this build's compiler (NDEBUG's use,
// M_PI, EDOM, EOF, errno, INFINITY, ...): a model's name that is one would be replaced in the
// generated C++ and break it. The list is the compiler's own, `-dM -E` at configure time
// (symbolic/CMakeLists.txt).
bool IsMacro(const std::string& name) {
  static const std::set<std::string> kMacros = {
#include "macro_names.inc"
  };
  return kMacros.count(name) > 0 || name == "NDEBUG";
}

// Quantity kinds the runtime knows (vlt/units.h DimensionName): job files give values in units
// of this kind.
const std::set<std::string>& QuantityKinds() {
  static const std::set<std::string> kKinds = {
      "length",   "angle",    "ratio",    "temperature",           "temperature difference",
      "pressure", "humidity", "fraction", "expansion coefficient", "dimensionless",
      "time"};
  return kKinds;
}

const std::set<std::string>& Distributions() {
  static const std::set<std::string> kDistributions = {"normal",  "rectangular", "triangular",
                                                       "arcsine", "student_t",   "curvilinear_trapezoid"};
  return kDistributions;
}

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const {
    throw SpecError(path_ + ": " + key + ": " + problem);
  }

  void CheckKeys(const toml::table& table, const std::string& where,
                 const std::set<std::string>& allowed) const {
    for (auto&& [key, value] : table) {
      (void)value;
      const std::string k(key.str());
      if (!allowed.count(k)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        Fail(where + "." + k, "unknown key (allowed: " + list + ")");
      }
    }
  }

  std::string String(const toml::table& table, const std::string& where, const std::string& key,
                     bool required, const std::string& fallback = "") const {
    const toml::node* node = table.get(key);
    if (!node) {
      if (required) Fail(where + "." + key, "missing (a string is required)");
      return fallback;
    }
    auto value = node->value<std::string>();
    if (!node->is_string() || !value) Fail(where + "." + key, "must be a string");
    if (value->empty()) Fail(where + "." + key, "must not be empty");
    // Every text of a spec goes into generated C++ (comments, string literals): one line of
    // printable characters, no control character a compiler would read as a line end (\r too).
    for (const char c : *value) {
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
        Fail(where + "." + key, "must be one line without control characters");
    }
    return *value;
  }

  double Number(const toml::table& table, const std::string& where, const std::string& key, bool required,
                double fallback = 0.0) const {
    const toml::node* node = table.get(key);
    if (!node) {
      if (required) Fail(where + "." + key, "missing (a number is required)");
      return fallback;
    }
    if (!node->is_number()) Fail(where + "." + key, "must be a number");
    const double v = *node->value<double>();
    if (!std::isfinite(v)) Fail(where + "." + key, "must be finite");
    return v;
  }

  QuantitySpec Quantity(const toml::table& table, const std::string& where, bool is_output,
                        bool is_custom) const {
    QuantitySpec q;
    if (is_output) {
      CheckKeys(table, where, {"name", "unit", "quantity", "description", "expression"});
    } else if (is_custom) {
      CheckKeys(table, where,
                {"name", "unit", "quantity", "description", "estimate", "u", "distribution", "shape"});
    } else {
      CheckKeys(table, where,
                {"name", "unit", "quantity", "description", "estimate", "u", "distribution", "shape"});
    }
    q.name = String(table, where, "name", true);
    if (!IsValidIdentifier(q.name)) {
      Fail(where + ".name", "'" + q.name +
                                "' is not a valid name (a letter first, then letters, "
                                "digits, '_'; not a C++ keyword, a C library macro such as M_PI or "
                                "EDOM, or a name the generated code uses)");
    }
    const std::string w = where + "(" + q.name + ")";
    q.unit = String(table, w, "unit", true);
    q.quantity = String(table, w, "quantity", !is_output, "");
    // Tracker models use the kinds whose units vlt reads; a custom model may name any quantity
    // ("voltage", "mass"): its job values are then plain numbers in the spec's unit.
    const bool plain_words = !q.quantity.empty() &&
                             q.quantity.find_first_not_of("abcdefghijklmnopqrstuvwxyz ") == std::string::npos;
    if (!q.quantity.empty() && !QuantityKinds().count(q.quantity) && !(is_custom && plain_words)) {
      std::string list;
      for (const auto& k : QuantityKinds()) list += (list.empty() ? "" : ", ") + k;
      Fail(w + ".quantity", "unknown quantity kind '" + q.quantity + "' (" + list +
                                (is_custom ? "; or lower-case words for a custom model" : "") + ")");
    }
    q.description = String(table, w, "description", true);
    if (q.description.find('\n') != std::string::npos) Fail(w + ".description", "must be one line");
    if (is_output) {
      q.expression = String(table, w, "expression", true);
      CheckExpressionText(q.expression, w + ".expression");
      return q;
    }
    q.estimate = Number(table, w, "estimate", is_custom, 0.0);
    q.u = Number(table, w, "u", true);
    if (q.u < 0) Fail(w + ".u", "standard uncertainty must not be negative");
    q.distribution = String(table, w, "distribution", false, "normal");
    if (!Distributions().count(q.distribution)) {
      std::string list;
      for (const auto& d : Distributions()) list += (list.empty() ? "" : ", ") + d;
      Fail(w + ".distribution", "unknown distribution '" + q.distribution + "' (" + list + ")");
    }
    q.shape = Number(table, w, "shape", false, 0.0);
    return q;
  }

  const std::string& path() const { return path_; }

  // Before GiNaC's parser (which recurses per level: 200 000 nested parentheses overflowed its
  // stack; a product of 10^5 factors ran for minutes): at most kMaxExpressionLength characters and
  // kMaxExpressionDepth levels of parentheses.
  void CheckExpressionText(const std::string& text, const std::string& where) const {
    if (text.size() > kMaxExpressionLength) {
      Fail(where, std::to_string(text.size()) + " characters, more than " + std::to_string(kMaxExpressionLength));
    }
    int depth = 0;
    for (const char c : text) {
      depth += c == '(' ? 1 : c == ')' ? -1 : 0;
      if (depth > kMaxExpressionDepth) {
        Fail(where, "parentheses or calls nested more than " + std::to_string(kMaxExpressionDepth) + " deep");
      }
    }
    // GiNaC computes a number's power and a literal exactly while it parses (1e100000000000,
    // 2^100000000000 ran out of memory): a literal's exponent or a power's literal of more than
    // three digits is refused here, as CheckExpression would refuse its value.
    auto digits_from = [&](std::size_t i) {
      while (i < text.size() && (text[i] == ' ' || text[i] == '(' || text[i] == '+' || text[i] == '-')) ++i;
      std::size_t n = 0;
      while (i + n < text.size() && std::isdigit(static_cast<unsigned char>(text[i + n]))) ++n;
      return n;
    };
    for (std::size_t i = 1; i < text.size(); ++i) {
      const bool exponent_mark = (text[i] == 'e' || text[i] == 'E') &&
                                 (std::isdigit(static_cast<unsigned char>(text[i - 1])) || text[i - 1] == '.');
      if (exponent_mark && digits_from(i + 1) > 3) Fail(where, "a number beyond the range of a double");
      if (text[i] == '^' && digits_from(i + 1) > 3) {
        Fail(where, "an integer power above " + std::to_string(kMaxIntegerPower));
      }
    }
  }

 private:
  std::string path_;
};

}  // namespace

bool IsValidIdentifier(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  if (!(name[0] >= 'a' && name[0] <= 'z') && !(name[0] >= 'A' && name[0] <= 'Z')) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    if (!ok) return false;
  }
  if (name.find("__") != std::string::npos) return false;
  if (name.rfind("_tmp", 0) == 0) return false;
  return !ReservedNames().count(name) && !IsMacro(name);
}

ModelSpec ReadSpec(const std::string& path, const std::string& spec_prefix) {
  Reader r(path);
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw SpecError(path + ":" + std::to_string(e.source().begin.line) +
                    ": TOML syntax: " + std::string(e.description()));
  }
  ModelSpec spec;
  spec.path = path;
  spec.spec_file = spec_prefix + std::filesystem::path(path).filename().string();
  r.CheckKeys(root, "", {"model", "parameter", "input", "output"});
  const toml::table* model = root["model"].as_table();
  if (!model) r.Fail("[model]", "missing table [model]");
  r.CheckKeys(*model, "model", {"name", "kind", "architecture", "description"});
  spec.name = r.String(*model, "model", "name", true);
  if (!IsValidIdentifier(spec.name)) r.Fail("model.name", "'" + spec.name + "' is not a valid name");
  const std::string stem = std::filesystem::path(path).stem().string();
  if (stem != spec.name) {
    r.Fail("model.name", "'" + spec.name + "' must equal the file name stem '" + stem + "'");
  }
  spec.kind = r.String(*model, "model", "kind", true);
  spec.description = r.String(*model, "model", "description", true);
  if (spec.kind == "tracker") {
    spec.architecture = r.String(*model, "model", "architecture", true);
    if (spec.architecture != "mirror" && spec.architecture != "head") {
      r.Fail("model.architecture", "unknown architecture '" + spec.architecture + "' (mirror, head)");
    }
    if (root.contains("input")) r.Fail("[[input]]", "only custom models have [[input]]");
    if (root.contains("output")) r.Fail("[[output]]", "tracker outputs are fixed (x, y, z)");
  } else if (spec.kind == "custom") {
    if (model->contains("architecture")) r.Fail("model.architecture", "only for kind = \"tracker\"");
    if (root.contains("parameter")) {
      r.Fail("[[parameter]]", "custom models declare [[input]], not [[parameter]]");
    }
  } else {
    r.Fail("model.kind", "must be \"tracker\" or \"custom\", not '" + spec.kind + "'");
  }

  const bool custom = spec.kind == "custom";
  auto read_array = [&](const char* key, bool is_output) {
    std::vector<QuantitySpec> out;
    const toml::node* node = root.get(key);
    if (!node) return out;
    const toml::array* array = node->as_array();
    if (!array) r.Fail(std::string("[[") + key + "]]", "must be an array of tables");
    std::set<std::string> seen;
    for (std::size_t i = 0; i < array->size(); ++i) {
      const std::string where = std::string(key) + "[" + std::to_string(i) + "]";
      const toml::table* t = (*array)[i].as_table();
      if (!t) r.Fail(where, "must be a table");
      QuantitySpec q = r.Quantity(*t, where, is_output, custom);
      if (!seen.insert(q.name).second) r.Fail(where + ".name", "duplicate name '" + q.name + "'");
      out.push_back(std::move(q));
    }
    return out;
  };
  if (custom) {
    spec.params = read_array("input", false);
    spec.outputs = read_array("output", true);
    if (spec.params.empty()) r.Fail("[[input]]", "a custom model needs at least one input");
    if (spec.outputs.empty()) r.Fail("[[output]]", "a custom model needs at least one output");
    // The generated code grows with the inputs squared (the Hessians): 3000 inputs exhausted the
    // compiler's memory. A measurement model of more is a model of several measurements.
    if (spec.params.size() > kMaxCustomInputs || spec.outputs.size() > kMaxCustomOutputs) {
      r.Fail(spec.params.size() > kMaxCustomInputs ? "[[input]]" : "[[output]]",
             "at most " + std::to_string(kMaxCustomInputs) + " inputs and " + std::to_string(kMaxCustomOutputs) +
                 " outputs in a custom model");
    }
    for (const auto& o : spec.outputs) {
      for (const auto& p : spec.params) {
        if (o.name == p.name) r.Fail("output(" + o.name + ").name", "same name as an input");
      }
    }
  } else {
    spec.params = read_array("parameter", false);
  }
  return spec;
}

}  // namespace vlt::gen
