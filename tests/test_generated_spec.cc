// vlt-gen driven on temporary specs (the binary at VLT_BINARY_DIR/symbolic/vlt-gen):
//  - a parameter removed from a spec disappears from the generated code and metadata;
//  - bad specs are refused with exit status 2 and one line naming the file and the key;
//  - the output does not depend on the process (two runs, byte-identical);
//  - --summary describes a model.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace fs = std::filesystem;

namespace {

const std::string kGen = VLT_BINARY_DIR "/symbolic/vlt-gen";
const fs::path kModels = fs::path(VLT_SOURCE_DIR) / "models";

std::string Read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void Write(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

// A fresh temporary directory per test.
fs::path TempDir() {
  std::string tmpl = (fs::temp_directory_path() / "vlt-gen-test-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
  return tmpl;
}

struct GenRun {
  int status;
  std::string out;
  std::string err;
};

GenRun RunGen(const std::string& args, const fs::path& dir) {
  const std::string cmd =
      kGen + " " + args + " > " + (dir / "stdout").string() + " 2> " + (dir / "stderr").string();
  const int raw = std::system(cmd.c_str());
  GenRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = Read(dir / "stdout");
  r.err = Read(dir / "stderr");
  return r;
}

// The spec text with the [[parameter]] block named `name` removed.
std::string WithoutParameter(const std::string& spec, const std::string& name) {
  const std::string marker = "[[parameter]]";
  std::string out;
  std::size_t pos = 0;
  bool removed = false;
  while (true) {
    const std::size_t start = spec.find(marker, pos);
    if (start == std::string::npos) {
      out += spec.substr(pos);
      break;
    }
    out += spec.substr(pos, start - pos);
    std::size_t end = spec.find(marker, start + marker.size());
    if (end == std::string::npos) end = spec.size();
    const std::string block = spec.substr(start, end - start);
    if (block.find("name = \"" + name + "\"") != std::string::npos) {
      removed = true;
    } else {
      out += block;
    }
    pos = end;
  }
  if (!removed) throw std::runtime_error("parameter not found in spec: " + name);
  return out;
}

TEST(VltGen, RemovedParameterDisappearsFromCodeAndMetadata) {
  const fs::path dir = TempDir();
  fs::create_directories(dir / "models");
  Write(dir / "models" / "mirror.toml", WithoutParameter(Read(kModels / "mirror.toml"), "tmv"));
  const GenRun r = RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string header = Read(dir / "out" / "mirror.h");
  const std::string source = Read(dir / "out" / "mirror.cc");
  ASSERT_FALSE(header.empty());
  EXPECT_EQ(header.find("tmv"), std::string::npos);
  EXPECT_EQ(source.find("tmv"), std::string::npos);
  EXPECT_NE(header.find("kNumParams = 19;"), std::string::npos);
  // The checked-in model (all parameters) has it, and the reduced one still has the others.
  EXPECT_NE(Read(fs::path(VLT_SOURCE_DIR) / "generated" / "mirror.h").find("Sensitivity_tmv"),
            std::string::npos);
  EXPECT_NE(header.find("Sensitivity_rmv"), std::string::npos);
  EXPECT_NE(source.find("{\"rmv\", \"rad\", \"angle\""), std::string::npos);
  // Only the specs given are in the registry.
  const std::string registry = Read(dir / "out" / "registry.cc");
  EXPECT_NE(registry.find("&kModel_mirror"), std::string::npos);
  EXPECT_EQ(registry.find("kModel_head"), std::string::npos);
  EXPECT_NE(registry.find("kNumModels = 1;"), std::string::npos);
  fs::remove_all(dir);
}

TEST(VltGen, OutputIsByteIdenticalAcrossRuns) {
  const fs::path dir = TempDir();
  ASSERT_EQ(RunGen("--models " + kModels.string() + " --out " + (dir / "a").string(), dir).status, 0);
  ASSERT_EQ(RunGen("--models " + kModels.string() + " --out " + (dir / "b").string(), dir).status, 0);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir / "a")) {
    EXPECT_EQ(Read(entry.path()), Read(dir / "b" / entry.path().filename())) << entry.path();
    ++files;
  }
  EXPECT_GE(files, 9);  // 4 models x 2 files + registry
  fs::remove_all(dir);
}

struct BadSpec {
  const char* what;
  std::string text;
  const char* expected_in_message;
};

TEST(VltGen, BadSpecsAreRefusedWithOneLineNamingFileAndKey) {
  const std::string mirror = Read(kModels / "mirror.toml");
  auto replace = [](std::string s, const std::string& from, const std::string& to) {
    const std::size_t p = s.find(from);
    if (p == std::string::npos) throw std::runtime_error("not found: " + from);
    return s.replace(p, from.size(), to);
  };
  const BadSpec cases[] = {
      {"unknown parameter", replace(mirror, "name = \"tmv\"", "name = \"tmx\""), "(tmx).name"},
      {"wrong unit", replace(mirror, "name = \"tmv\"\nunit = \"m\"", "name = \"tmv\"\nunit = \"mm\""),
       "(tmv).unit"},
      {"missing u", replace(mirror, "u = 5e-06", "# u removed"), ".u: missing"},
      {"negative u", replace(mirror, "u = 5e-06", "u = -5e-06"), ".u: standard uncertainty"},
      {"unknown key", replace(mirror, "[model]\n", "[model]\ncolour = \"red\"\n"), "model.colour"},
      {"unknown architecture", replace(mirror, "architecture = \"mirror\"", "architecture = \"scanner\""),
       "model.architecture"},
      {"TOML syntax", mirror + "\n[[parameter\n", "TOML syntax"},
      {"unknown distribution", replace(mirror, "distribution = \"normal\"", "distribution = \"gauss\""),
       ".distribution"},
  };
  for (const auto& c : cases) {
    const fs::path dir = TempDir();
    fs::create_directories(dir / "models");
    Write(dir / "models" / "mirror.toml", c.text);
    const GenRun r =
        RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
    EXPECT_EQ(r.status, 2) << c.what;
    EXPECT_NE(r.err.find((dir / "models" / "mirror.toml").string()), std::string::npos)
        << c.what << ": " << r.err;
    EXPECT_NE(r.err.find(c.expected_in_message), std::string::npos) << c.what << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.what << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out" / "mirror.h")) << c.what;
    fs::remove_all(dir);
  }
}

TEST(VltGen, CustomOutputExpressionMustUseDeclaredInputs) {
  const fs::path dir = TempDir();
  fs::create_directories(dir / "models");
  std::string spec = Read(kModels / "jcgm101_additive.toml");
  const std::string from = "expression = \"x1 + x2 + x3 + x4\"";
  spec.replace(spec.find(from), from.size(), "expression = \"x1 + x5\"");
  Write(dir / "models" / "jcgm101_additive.toml", spec);
  const GenRun r = RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("output[0](y).expression"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// What a custom spec could do to the generator or the compiler (a review of 2026-11-29 built
// hostile specs): a name that is a macro of the generated code's headers, a C++ keyword or a name
// of the generated code; a literal beyond a double, a complex number, an unsupported function, an
// integer power of 10^9, 10^5 nested parentheses, 3000 inputs. Each is one line naming the key,
// exit 2, nothing written, in well under a second (they had crashed vlt-gen, exhausted its memory,
// run for minutes or failed in the compiler).
TEST(VltGen, HostileCustomSpecsAreRefusedAtTheirKey) {
  const std::string additive = Read(kModels / "jcgm101_additive.toml");
  auto with = [&](const std::string& from, const std::string& to) {
    std::string s = additive;
    const std::size_t p = s.find(from);
    if (p == std::string::npos) throw std::runtime_error("not found: " + from);
    return s.replace(p, from.size(), to);
  };
  const std::string sum = "expression = \"x1 + x2 + x3 + x4\"";
  std::string many_inputs = additive;
  for (int i = 0; i < 101; ++i) {
    many_inputs += "\n[[input]]\nname = \"extra" + std::to_string(i) +
                   "\"\nunit = \"1\"\nquantity = \"dimensionless\"\ndescription = \"d\"\nestimate = 1.0\nu = 0.1\n";
  }
  const BadSpec cases[] = {
      {"a macro", with("name = \"x1\"", "name = \"EDOM\""), "input[0].name: 'EDOM' is not a valid name"},
      {"M_PI", with("name = \"x1\"", "name = \"M_PI\""), "input[0].name: 'M_PI' is not a valid name"},
      {"errno", with("name = \"x1\"", "name = \"errno\""), "input[0].name: 'errno' is not a valid name"},
      {"a keyword", with("name = \"x1\"", "name = \"nullptr\""), "input[0].name: 'nullptr' is not a valid name"},
      {"generated", with("name = \"x1\"", "name = \"SinCos\""), "input[0].name: 'SinCos' is not a valid name"},
      {"huge literal", with(sum, "expression = \"x1 * 1e400 + x2 + x3 + x4\""), "a number beyond the range of a double"},
      {"complex", with(sum, "expression = \"sqrt(-1) * x1 + x2 + x3 + x4\""), "a complex number"},
      {"abs", with(sum, "expression = \"abs(x1) + x2 + x3 + x4\""), "function 'abs' is not supported"},
      {"power", with(sum, "expression = \"x1^1000000000 + x2 + x3 + x4\""), "an integer power above 64"},
      {"power beyond int", with(sum, "expression = \"x1^4294967298 + x2 + x3 + x4\""), "an integer power above 64"},
      // GiNaC computes these exactly while parsing (they ran out of memory): refused from the text.
      {"number's power", with(sum, "expression = \"x1 * 2^100000000000 + x2 + x3 + x4\""), "an integer power above 64"},
      {"literal's exponent", with(sum, "expression = \"x1 * 1e100000000000 + x2 + x3 + x4\""),
       "a number beyond the range of a double"},
      {"nesting", with(sum, "expression = \"" + std::string(100000, '(') + "x1" + std::string(100000, ')') + "\""),
       "characters, more than 4096"},
      {"depth", with(sum, "expression = \"" + std::string(33, '(') + "x1" + std::string(33, ')') + " + x2 + x3 + x4\""),
       "nested more than 32 deep"},
      {"inputs", many_inputs, "[[input]]: at most 100 inputs and 100 outputs"},
  };
  for (const auto& c : cases) {
    const fs::path dir = TempDir();
    fs::create_directories(dir / "models");
    Write(dir / "models" / "jcgm101_additive.toml", c.text);
    const GenRun r = RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
    EXPECT_EQ(r.status, 2) << c.what << ": " << r.err;
    EXPECT_NE(r.err.find((dir / "models" / "jcgm101_additive.toml").string()), std::string::npos) << c.what << ": " << r.err;
    EXPECT_NE(r.err.find(c.expected_in_message), std::string::npos) << c.what << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.what << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out" / "jcgm101_additive.h")) << c.what;
    fs::remove_all(dir);
  }
}

TEST(VltGen, ExpressionsUndefinedAtZeroGenerateAndSingularOnesAreRefused) {
  // v/i (and 1/i) have no value at i = 0: the nominal Jacobian is taken at the estimates, so the
  // spec generates; with the estimate i = 0 itself the spec is refused with one line, exit 2.
  auto spec = [](double i_estimate) {
    return std::string(
               "[model]\nname = \"ohm\"\nkind = \"custom\"\ndescription = \"R = V / I\"\n\n"
               "[[input]]\nname = \"v\"\nunit = \"1\"\nquantity = \"dimensionless\"\ndescription = "
               "\"voltage\"\n"
               "estimate = 5.0\nu = 0.01\ndistribution = \"normal\"\n\n"
               "[[input]]\nname = \"i\"\nunit = \"1\"\nquantity = \"dimensionless\"\ndescription = "
               "\"current\"\n"
               "estimate = ") +
           std::to_string(i_estimate) +
           "\nu = 0.001\ndistribution = \"normal\"\n\n[[output]]\nname = \"r\"\nunit = \"1\"\nquantity = "
           "\"dimensionless\"\n"
           "description = \"resistance\"\nexpression = \"v/i + sqrt(v^2 + i^2) - sqrt(v^2 + i^2)\"\n";
  };
  const fs::path dir = TempDir();
  fs::create_directories(dir / "models");
  Write(dir / "models" / "ohm.toml", spec(0.5));
  GenRun r = RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  const std::string header = Read(dir / "out" / "ohm.h");
  EXPECT_NE(header.find("out[0] = 10.0;"), std::string::npos) << header;  // 5 / 0.5 at the estimates
  Write(dir / "models" / "ohm.toml", spec(0.0));
  fs::remove_all(dir / "out");
  r = RunGen("--models " + (dir / "models").string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("ohm.toml: the model or its Jacobian is singular at the inputs' estimates"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "ohm.h"));
  fs::remove_all(dir);
}

TEST(VltGen, SummaryListsParametersAndOperationCounts) {
  const fs::path dir = TempDir();
  const GenRun r = RunGen("--summary " + (kModels / "head.toml").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("model       head"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("lam"), std::string::npos);
  EXPECT_NE(r.out.find("ForwardJacobians"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace

// Where a kernel uses both sin a and cos a, the generator emits one SinCos(a, &s, &c) (one range
// reduction in the SIMD lanes) and no sin(a) or cos(a) call beside it; each angle once per kernel.
TEST(VltGen, EachAngleOfAKernelHasOneSinCos) {
  int pairs = 0;
  for (const char* model : {"mirror", "head", "total_station", "gum_h2_impedance"}) {
    const std::string text = Read(fs::path(VLT_SOURCE_DIR) / "generated" / (std::string(model) + ".h"));
    std::size_t at = 0;
    while ((at = text.find("\ntemplate <typename Scalar>\nvoid ", at)) != std::string::npos) {
      const std::size_t end = text.find("\n}\n", at);
      const std::string kernel = text.substr(at, end - at);
      at = end;
      std::set<std::string> paired;
      for (std::size_t p = 0; (p = kernel.find("  SinCos(", p)) != std::string::npos; ++p) {
        const std::size_t open = p + 9, comma = kernel.find(',', open);
        const std::string angle = kernel.substr(open, comma - open);
        EXPECT_TRUE(paired.insert(angle).second) << model << ": SinCos(" << angle << ") twice";
        EXPECT_EQ(kernel.find("sin(" + angle + ")"), std::string::npos) << model << ": sin(" << angle << ")";
        EXPECT_EQ(kernel.find("cos(" + angle + ")"), std::string::npos) << model << ": cos(" << angle << ")";
        ++pairs;
      }
    }
  }
  EXPECT_GE(pairs, 9);  // the mirror model's Forward alone has nine angles
}
