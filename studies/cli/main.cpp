// shadefit: fits shading models to reference images and measures which effects they reproduce.
#include <cstdio>
#include <exception>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/version.h"

int main(int argc, char** argv) {
  CLI::App app{"shadefit: fit Blinn-Phong and microfacet shading models to reference images"};
  app.require_subcommand(1);
  app.set_version_flag("--version", SHADEFIT_VERSION_STRING);
  using namespace shadefit::cli;
  RegisterInfoCommand(app);
  RegisterModelsCommand(app);
  RegisterRenderCommand(app);
  RegisterMetricsCommand(app);
  RegisterFitCommand(app);
  RegisterRefsCommand(app);
  RegisterProbeCommand(app);
  RegisterStudyCommand(app);
  RegisterReportCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are ParseErrors with exit code 0: CLI11 prints them. A real parse
    // error gets the one-line form of every other error (CLI11 would add a second line).
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "shadefit: error: %s\n", shadefit::OneLine(e.what()).c_str());
    return e.get_exit_code();
  } catch (const shadefit::Error& e) {
    std::fprintf(stderr, "shadefit: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shadefit: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
