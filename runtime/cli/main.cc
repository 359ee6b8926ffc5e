// vlt — the Virtual Laser Tracker command line. Each subcommand lives in cmd_<name>.cc.
// Exit status: 0 success, 2 bad input or a result that cannot be computed (one line on stderr).
// Under mpirun every rank runs this; rank 0 prints and writes (docs/mpi.md).
#include <cstdio>
#include <exception>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "vlt/mpi.h"
#include "vlt/error.h"
#include "vlt/results.h"

namespace vlt::cli {

// An error line quotes what the user wrote ('...'); a 2 MB CSV cell must not become a 2 MB line.
// Quoted values longer than 160 characters keep their first and last 60 (a path keeps its file
// name, which is what the user needs to see); a line still longer than 1000 (a long path outside
// quotes) keeps its first and last 480: the problem, at the end of the line, is never cut.
namespace {

// One line that a terminal shows as it is: a line break or a tab a blank; any other C0 control
// or DEL (an escape sequence; NUL would end the printed text) as \xNN; a C1 control (U+0080..
// U+009F: CSI introduces a terminal's escape too) or a bidirectional mark, embedding, override or
// isolate (U+061C, U+200E/F, U+202A..E, U+2066..9: they reorder what a reader sees) as \uXXXX.
std::string VisibleText(const std::string& text) {
  std::string visible;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto byte = [&](std::size_t k) { return k < text.size() ? static_cast<unsigned char>(text[k]) : 0u; };
    const unsigned c = byte(i), c1 = byte(i + 1), c2 = byte(i + 2);
    char escaped[16];
    if (c == '\n' || c == '\r' || c == '\t') {
      visible += ' ';
    } else if (c < 0x20 || c == 0x7f) {
      std::snprintf(escaped, sizeof escaped, "\\x%02X", c);
      visible += escaped;
    } else if ((c == 0xc2 && c1 >= 0x80 && c1 <= 0x9f) || (c == 0xd8 && c1 == 0x9c)) {
      std::snprintf(escaped, sizeof escaped, "\\u%04X", ((c & 0x1fu) << 6) | (c1 & 0x3fu));
      visible += escaped;
      ++i;
    } else if (c == 0xe2 && ((c1 == 0x80 && (c2 == 0x8e || c2 == 0x8f || (c2 >= 0xaa && c2 <= 0xae))) ||
                             (c1 == 0x81 && c2 >= 0xa6 && c2 <= 0xa9))) {
      std::snprintf(escaped, sizeof escaped, "\\u%04X", ((c & 0x0fu) << 12) | ((c1 & 0x3fu) << 6) | (c2 & 0x3fu));
      visible += escaped;
      i += 2;
    } else {
      visible += static_cast<char>(c);
    }
  }
  return visible;
}

}  // namespace

std::string ShortenMessage(const std::string& message) {
  std::string out;
  std::size_t i = 0;
  while (i < message.size()) {
    const std::size_t open = message.find('\'', i);
    const std::size_t close = open == std::string::npos ? std::string::npos : message.find('\'', open + 1);
    if (close == std::string::npos) {
      out += message.substr(i);
      break;
    }
    out += message.substr(i, open + 1 - i);
    const std::size_t length = close - open - 1;
    if (length > 160) {
      out += message.substr(open + 1, 60) + "...(" + std::to_string(length) + " characters)..." +
             message.substr(close - 60, 60);
    } else {
      out += message.substr(open + 1, length);
    }
    out += '\'';
    i = close + 1;
  }
  out = VisibleText(out);
  if (out.size() > 1000) {
    const std::size_t left_out = out.size() - 960;
    out = out.substr(0, 480) + " ...(" + std::to_string(left_out) + " characters)... " +
          out.substr(out.size() - 480);
  }
  return out;
}

void EmitWarnings(const std::vector<std::string>& warnings, const GlobalOptions& global) {
  if (warnings.empty()) return;
  if (global.strict) throw InputError(warnings.front() + " (a warning; --strict makes it an error)");
  if (global.quiet) return;
  for (const std::string& w : warnings) std::fprintf(stderr, "vlt: warning: %s\n", ShortenMessage(w).c_str());
}

// The one error line and the exit status (docs/cli.md): 2 for what the user gave (input, or a
// result that cannot be computed from it), 3 for an internal error.
int ReportFailure(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const InputError& e) {
    std::fprintf(stderr, "vlt: error: %s\n", ShortenMessage(e.what()).c_str());
    return 2;
  } catch (const NumericalError& e) {
    std::fprintf(stderr, "vlt: error: %s\n", ShortenMessage(e.what()).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vlt: internal error: %s\n", ShortenMessage(e.what()).c_str());
    return 3;
  } catch (...) {
    std::fprintf(stderr, "vlt: internal error: unknown exception\n");
    return 3;
  }
}

}  // namespace vlt::cli

int main(int argc, char** argv) {
  // MPI_Init / MPI_Finalize when built with -DVLT_MPI=ON and started by mpirun (docs/mpi.md).
  vlt::ranks::Session ranks(&argc, &argv);
  CLI::App app{
      "vlt — the Virtual Laser Tracker: GUM and Monte Carlo uncertainty of laser "
      "tracker measurements from an explicit model of the instrument"};
  // Version, the commit the build was configured from, and the build type (runtime/CMakeLists.txt).
  app.set_version_flag("--version", std::string("vlt ") + VLT_VERSION + " (commit " + vlt::VltCommit() +
                                        ", " + vlt::VltBuildType() + " build)");
  vlt::cli::GlobalOptions global;
  app.add_flag("-q,--quiet", global.quiet, "Print nothing but errors");
  app.add_flag("--json", global.json, "Print results as JSON where a command prints results");
  app.add_flag("--strict", global.strict, "Treat warnings (implausible but legal input) as errors");
  app.require_subcommand(0, 1);
  app.fallthrough();

  vlt::cli::AddDemoCommand(app, global);
  vlt::cli::AddRunCommand(app, global);
  vlt::cli::AddMapCommand(app, global);
  vlt::cli::AddPlanCommand(app, global);
  vlt::cli::AddTestCommand(app, global);
  vlt::cli::AddCalibrateCommand(app, global);
  vlt::cli::AddPriorCommand(app, global);
  vlt::cli::AddNetworkCommand(app, global);
  vlt::cli::AddSimulateCommand(app, global);
  vlt::cli::AddModelCommand(app, global);

  vlt::InstallOutputSignalHandlers();
  int status = 0;
  try {
    try {
      app.parse(argc, argv);
      if (app.get_subcommands().empty()) status = vlt::cli::RunDemo(global);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() != 0) {
        // One line, like every other error (docs/cli.md): CLI11's text without its second line.
        std::string message = e.what();
        for (char& c : message) {
          if (c == '\n' || c == '\r') c = ' ';
        }
        throw vlt::InputError("command line: " + message + " (vlt --help)");
      }
      status = app.exit(e);  // --help, --version
    }
    // Under MPI the ranks agree that none failed (vlt/mpi/ranks.h); without MPI nothing happens.
    vlt::ranks::Agree();
  } catch (...) {
    std::exception_ptr failure = std::current_exception();
    if (!vlt::ranks::FailureAgreed()) {
      // Meet the other ranks at their next agreement: every rank ends with the failure of the
      // lowest failed rank, and rank 0 prints it.
      try {
        vlt::ranks::Agree(failure);
      } catch (...) {
        failure = std::current_exception();
      }
    }
    return vlt::cli::ReportFailure(failure);
  }
  return status;
}
