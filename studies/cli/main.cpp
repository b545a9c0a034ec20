// shadefit: fits shading models to reference images and measures which effects they reproduce.
#include <cstdio>
#include <exception>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/version.h"

namespace {

// A study's jobs make and free many frame-sized images (a 612x512 RGBA float frame is 5 MB; a
// fit job on a 96-light photo set touches hundreds), from several worker threads. glibc's
// defaults hand blocks above its mmap threshold to the kernel on every free and trim the heap
// top as soon as it passes 128 kB, so each new image is a fresh mapping the kernel zeroes page
// by page. Keeping freed memory for reuse instead: the 96-light photo job ran 154.9 -> 133.1 CPU-s
// (BENCHMARKS.md). The cost is that the process keeps its peak memory until it exits.
void KeepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest; larger blocks are still mapped.
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  KeepFreedMemory();
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
