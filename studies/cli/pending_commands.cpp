// Subcommands whose implementation has not landed yet. Each says so and exits non-zero rather
// than pretending to work; they move to their own files as their issues land.
#include "commands.h"
#include "shadefit/render/error.h"

namespace shadefit::cli {
namespace {
void Pending(CLI::App& app, const char* name, const char* what) {
  auto* cmd = app.add_subcommand(name, std::string(what) + " (not implemented yet)");
  cmd->allow_extras();
  cmd->callback([name] { throw Error("", name, "this subcommand is not implemented yet"); });
}
}  // namespace

void RegisterFitCommand(CLI::App& app) { Pending(app, "fit", "Fit a model to references"); }
void RegisterProbeCommand(CLI::App& app) { Pending(app, "probe", "Phenomenon probes"); }
void RegisterStudyCommand(CLI::App& app) { Pending(app, "study", "Run a study"); }
void RegisterReportCommand(CLI::App& app) { Pending(app, "report", "Make a study's report"); }
}  // namespace shadefit::cli
