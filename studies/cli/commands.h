// Subcommands of the `shadefit` executable. Each lives in its own <name>_command.cpp and adds
// itself to the CLI11 app; main.cpp calls every Register function, parses, and turns any
// shadefit::Error (or other exception) into a one-line message and exit code 1.
#pragma once

#include <CLI/CLI.hpp>

namespace shadefit::cli {

void RegisterInfoCommand(CLI::App& app);     // info: EGL device and GL strings
void RegisterModelsCommand(CLI::App& app);   // models: parameter tables
void RegisterRenderCommand(CLI::App& app);   // render: scene + model -> EXR + PNG (+ AOVs)
void RegisterMetricsCommand(CLI::App& app);  // metrics: image metrics between two images
void RegisterFitCommand(CLI::App& app);      // fit: Ceres fit of a model to references
void RegisterRefsCommand(CLI::App& app);     // refs: cycles | measured | import
void RegisterProbeCommand(CLI::App& app);    // probe: phenomenon probes
void RegisterStudyCommand(CLI::App& app);    // study run
void RegisterReportCommand(CLI::App& app);   // report: tables and figures from a study

}  // namespace shadefit::cli
