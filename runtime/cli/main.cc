// vlt — the Virtual Laser Tracker command line. Each subcommand lives in cmd_<name>.cc.
// Exit status: 0 success, 2 bad input or a result that cannot be computed (one line on stderr).
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "vlt/error.h"

int main(int argc, char** argv) {
  CLI::App app{"vlt — the Virtual Laser Tracker: GUM and Monte Carlo uncertainty of laser "
               "tracker measurements from an explicit model of the instrument"};
  app.set_version_flag("--version", std::string("vlt ") + VLT_VERSION);
  vlt::cli::GlobalOptions global;
  app.add_flag("-q,--quiet", global.quiet, "Print nothing but errors");
  app.add_flag("--json", global.json, "Print results as JSON where a command prints results");
  app.require_subcommand(0, 1);
  app.fallthrough();

  vlt::cli::AddDemoCommand(app, global);
  vlt::cli::AddRunCommand(app, global);
  vlt::cli::AddMapCommand(app, global);
  vlt::cli::AddTestCommand(app, global);
  vlt::cli::AddCalibrateCommand(app, global);
  vlt::cli::AddSimulateCommand(app, global);
  vlt::cli::AddModelCommand(app, global);

  try {
    app.parse(argc, argv);
    if (app.get_subcommands().empty()) return vlt::cli::RunDemo(global);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const vlt::InputError& e) {
    std::fprintf(stderr, "vlt: error: %s\n", e.what());
    return 2;
  } catch (const vlt::NumericalError& e) {
    std::fprintf(stderr, "vlt: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vlt: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
