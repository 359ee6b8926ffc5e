// `vlt demo` (and bare `vlt`): the embedded default job (runtime/src/job/default_job.cc) into
// ./vlt-demo/ — the README's first command.
#include <cstdio>
#include <filesystem>

#include "run_job.h"

namespace vlt::cli {
namespace {

Job DefaultJob() {
  // Relative paths in the embedded job (there are none) would resolve against the current directory.
  return ParseJob(DefaultJobToml(), std::string("(embedded) ") + kDefaultJobName,
                  std::filesystem::current_path());
}

}  // namespace

int RunDemo(const GlobalOptions& global) {
  RunCliOptions options;
  return RunAndWrite(DefaultJob(), options, global, "vlt-demo");
}

void AddDemoCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand("demo",
                                     "Run the embedded default job (a mirror tracker measuring a 4 m x 1.5 m "
                                     "panel) into ./vlt-demo/ — also what bare `vlt` does");
  auto options = std::make_shared<RunCliOptions>();
  auto show = std::make_shared<bool>(false);
  AddRunOptions(*command, *options, "./vlt-demo");
  command->add_flag("--show-job", *show,
                    "Print the embedded job file (a starting point for your own) and exit");
  command->callback([options, show, &global] {
    if (*show) {
      std::string_view text = DefaultJobToml();
      std::fwrite(text.data(), 1, text.size(), stdout);
      return;
    }
    RunAndWrite(DefaultJob(), *options, global, "vlt-demo");
  });
}

}  // namespace vlt::cli
