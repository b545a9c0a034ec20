// `shadefit metrics REF TEST [--mask M] [--json] [--exposure X] [--ppd P] [--itp-white NITS]
// [--maps DIR]`:
// every image metric between a reference and a test image (docs/metrics.md).
//
// Links: shadefit::metrics (brings shadefit::render), CLI11::CLI11, fmt::fmt.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/metrics/report.h"
#include "shadefit/render/image.h"

namespace shadefit::cli {
namespace {

struct MetricsOptions {
  std::string reference;
  std::string test;
  std::string mask;
  std::string maps;
  bool json = false;
  float exposure = 0.0f;
  double ppd = 67.0;
  double itp_white = 100.0;
};

std::string Fixed(double v, int decimals) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : std::string("inf");
}

void PrintTable(const metrics::MetricsReport& r, const MetricsOptions& o) {
  fmt::print("reference  {}\ntest       {}\n", o.reference, o.test);
  fmt::print("size       {}x{}, {} pixels evaluated{}\n", r.width, r.height, r.valid_pixels,
             r.masked ? " (mask " + o.mask + ")" : "");
  fmt::print("display    exposure {:+.2f} stops, sRGB OETF, clip [0, 1]; FLIP {} ppd\n\n",
             r.exposure_stops, r.ppd);
  const auto row = [](const char* name, const std::string& value, const char* note) {
    fmt::print("  {:<22} {:>12}  {}\n", name, value, note);
  };
  row("RMSE", Fixed(r.rmse, 6), "linear");
  row("relative RMSE", Fixed(r.relative_rmse, 6), "linear, eps 0.01");
  row("log RMSE", Fixed(r.log_rmse, 6), "linear, log(1 + x)");
  row("MAE", Fixed(r.mae, 6), "linear");
  row("PSNR", Fixed(r.psnr, 3), "dB, display");
  row("SSIM luminance", Fixed(r.ssim_luminance.mean, 6), "display");
  row("SSIM RGB", Fixed(r.ssim_rgb.mean, 6), "display, channel mean");
  row("MS-SSIM", Fixed(r.ms_ssim.value, 6),
      fmt::format("display luminance, {} scales", r.ms_ssim.scales_used).c_str());
  row("CIEDE2000 mean", Fixed(r.ciede2000.mean, 4), "display-referred linear sRGB");
  row("CIEDE2000 p95", Fixed(r.ciede2000.p95, 4), "");
  row("dE_ITP mean", Fixed(r.delta_e_itp.mean, 4),
      fmt::format("linear HDR, 1.0 = {:g} cd/m^2, PQ", r.itp_white_luminance).c_str());
  row("dE_ITP p95", Fixed(r.delta_e_itp.p95, 4), "");
  row("LDR-FLIP mean", Fixed(r.flip_ldr.mean, 6), "display-referred");
  row("LDR-FLIP p95", Fixed(r.flip_ldr.p95, 6), "");
  row("HDR-FLIP mean", Fixed(r.flip_hdr.mean, 6),
      fmt::format("exposures {:.2f}..{:.2f}, {} steps", r.flip_hdr.start_exposure,
                  r.flip_hdr.stop_exposure, r.flip_hdr.num_exposures)
          .c_str());
  row("HDR-FLIP p95", Fixed(r.flip_hdr.p95, 6), "");
}

void RunMetrics(const MetricsOptions& o) {
  // Check the output directory first: nothing is computed for a run that cannot finish.
  if (!o.maps.empty() && !std::filesystem::is_directory(o.maps)) {
    throw Error(o.maps, "--maps", "directory does not exist");
  }
  // CLI11 reads "nan" and "inf" as numbers; no display transform or observer means them. FLIP's
  // filters grow with ppd, so it is also bounded above (67 is a 0.7 m view of a 24" 4K screen).
  if (!std::isfinite(o.exposure) || std::abs(o.exposure) > 64) {
    throw Error("", "--exposure", fmt::format("{} stops is not in [-64, 64]", o.exposure));
  }
  if (!std::isfinite(o.ppd) || o.ppd > 1000) {
    throw Error("", "--ppd", fmt::format("{} pixels per degree is not in (0, 1000]", o.ppd));
  }
  if (!std::isfinite(o.itp_white) || o.itp_white <= 0 || o.itp_white > 10000) {
    throw Error("", "--itp-white", fmt::format("{} cd/m^2 is not in (0, 10000]", o.itp_white));
  }
  const Image reference = ReadImage(o.reference);
  const Image test = ReadImage(o.test);
  std::optional<Image> mask;
  if (!o.mask.empty()) mask = ReadImage(o.mask);

  metrics::MetricsParameters p;
  p.exposure_stops = o.exposure;
  p.ppd = o.ppd;
  p.itp_white_luminance = o.itp_white;
  p.names = {o.reference, o.test, o.mask};
  metrics::MetricsMaps maps;
  const metrics::MetricsReport report = metrics::ComputeMetrics(
      reference, test, mask ? &*mask : nullptr, p, o.maps.empty() ? nullptr : &maps);
  if (!o.maps.empty()) metrics::WriteMetricMaps(maps, o.maps);

  if (o.json) {
    nlohmann::json j = metrics::MetricsToJson(report);
    j["reference"] = o.reference;
    j["test"] = o.test;
    if (mask) j["mask"] = o.mask;
    fmt::print("{}\n", j.dump(2));
  } else {
    PrintTable(report, o);
  }
}

}  // namespace

void RegisterMetricsCommand(CLI::App& app) {
  auto options = std::make_shared<MetricsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "metrics", "Image metrics between a reference and a test image (linear HDR RGB)");
  cmd->add_option("reference", options->reference, "Reference image (EXR, linear RGB)")->required();
  cmd->add_option("test", options->test, "Test image, same size")->required();
  cmd->add_option("--mask", options->mask, "Single-channel mask image; pixels > 0.5 are evaluated");
  cmd->add_flag("--json", options->json,
                "Print JSON (schema shadefit.metrics/1) instead of a table");
  cmd->add_option("--exposure", options->exposure,
                  "Display-transform exposure in stops (PSNR, SSIM, CIEDE2000, LDR-FLIP)")
      ->capture_default_str();
  cmd->add_option("--ppd", options->ppd, "FLIP observer pixels per degree")
      ->check(CLI::Range(1e-3, 1000.0))
      ->capture_default_str();
  cmd->add_option("--itp-white", options->itp_white,
                  "Luminance in cd/m^2 of the linear value 1.0 for dE_ITP (BT.2124)")
      ->capture_default_str();
  cmd->add_option("--maps", options->maps,
                  "Existing directory for false-colour maps (abs/rel error, SSIM, CIEDE2000, "
                  "dE_ITP, FLIP)");
  cmd->callback([options] { RunMetrics(*options); });
}

}  // namespace shadefit::cli
