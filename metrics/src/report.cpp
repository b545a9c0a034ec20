#include "shadefit/metrics/report.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "shadefit/metrics/false_color.h"
#include "shadefit/metrics/pixel_metrics.h"
#include "shadefit/base/error.h"

namespace shadefit::metrics {
namespace {

// JSON has no infinities: non-finite numbers become null.
nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json FlipJson(const FlipResult& f, bool hdr) {
  nlohmann::json j = {{"mean", f.mean},
                      {"median", f.median},
                      {"p95", f.p95},
                      {"p99", f.p99},
                      {"max", f.max},
                      {"weighted_median", f.weighted_median},
                      {"weighted_q1", f.weighted_q1},
                      {"weighted_q3", f.weighted_q3},
                      {"histogram", f.histogram}};
  if (hdr) {
    j["start_exposure"] = Number(f.start_exposure);
    j["stop_exposure"] = Number(f.stop_exposure);
    j["num_exposures"] = f.num_exposures;
  }
  return j;
}

// Adds the seconds since the previous lap to the field a lap names (no clock without a target).
class MetricClock {
 public:
  explicit MetricClock(MetricsSeconds* target) : target_(target), last_(Clock::now()) {}
  void Lap(double MetricsSeconds::*field) {
    if (target_ == nullptr) return;
    const Clock::time_point now = Clock::now();
    target_->*field += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  using Clock = std::chrono::steady_clock;
  MetricsSeconds* target_;
  Clock::time_point last_;
};

}  // namespace

MetricsReport ComputeMetrics(const Image& reference, const Image& test, const Image* mask,
                             const MetricsParameters& p, MetricsMaps* maps) {
  MetricClock clock(p.seconds);
  ValidateInputs(reference, test, mask, 3, p.names);
  const auto wanted = [&](MetricMap map) { return maps != nullptr && (p.maps_wanted & map) != 0; };
  const Image ref = reference.channels == 3 ? reference : reference.Channels(0, 3);
  const Image tst = test.channels == 3 ? test : test.Channels(0, 3);

  MetricsReport r;
  r.width = ref.width;
  r.height = ref.height;
  r.masked = mask != nullptr;
  r.valid_pixels = CountValidPixels(mask, ref.width, ref.height);
  r.exposure_stops = p.exposure_stops;
  r.ppd = p.ppd;
  r.relative_epsilon = p.relative_epsilon;
  r.itp_white_luminance = p.itp_white_luminance;

  const PixelMetricParameters pixel{mask, p.relative_epsilon};
  r.rmse = Rmse(ref, tst, pixel);
  r.relative_rmse = RelativeRmse(ref, tst, pixel);
  r.log_rmse = LogRmse(ref, tst, pixel);
  r.mae = MeanAbsoluteError(ref, tst, pixel);
  r.psnr = Psnr(ref, tst, {p.exposure_stops, mask});
  clock.Lap(&MetricsSeconds::pixel);

  // Structural metrics on display-encoded values in [0, 1].
  SsimParameters ssim;
  ssim.data_range = 1.0;
  ssim.mask = mask;
  const Image ref_y = DisplayEncode(Luminance(ref), p.exposure_stops);
  const Image tst_y = DisplayEncode(Luminance(tst), p.exposure_stops);
  Image* ssim_map = wanted(kSsimMap) ? &maps->ssim : nullptr;
  try {
    r.ssim_luminance = Ssim(ref_y, tst_y, ssim, ssim_map);
    r.ssim_rgb =
        Ssim(DisplayEncode(ref, p.exposure_stops), DisplayEncode(tst, p.exposure_stops), ssim);
    MsSsimParameters ms;
    ms.ssim = ssim;
    r.ms_ssim = MsSsim(ref_y, tst_y, ms);
  } catch (const Error& e) {
    // The SSIM functions name their inputs generically; say which files were meant (and keep
    // the error's type).
    const std::string problem = std::string(e.what()) + " (test " + p.names.test +
                                (mask ? ", mask " + p.names.mask : "") + ")";
    if (dynamic_cast<const NoSsimWindowInMaskError*>(&e) != nullptr) {
      throw NoSsimWindowInMaskError(p.names.reference, "", problem);
    }
    throw Error(p.names.reference, "", problem);
  }
  clock.Lap(&MetricsSeconds::ssim);

  DeltaE2000Parameters de;
  de.exposure_stops = p.exposure_stops;
  de.mask = mask;
  r.ciede2000 = DeltaE2000(ref, tst, de, wanted(kCiede2000Map) ? &maps->ciede2000 : nullptr);
  clock.Lap(&MetricsSeconds::ciede2000);

  DeltaEItpParameters itp;
  itp.white_luminance = p.itp_white_luminance;
  itp.mask = mask;
  r.delta_e_itp = DeltaEItp(ref, tst, itp, wanted(kDeltaEItpMap) ? &maps->delta_e_itp : nullptr);
  clock.Lap(&MetricsSeconds::delta_e_itp);

  FlipParameters flip;
  flip.ppd = p.ppd;
  flip.mask = mask;
  flip.reference_cache = p.flip_reference_cache;
  r.flip_ldr = FlipLdr(ExposeAndClip(ref, p.exposure_stops), ExposeAndClip(tst, p.exposure_stops),
                       flip, wanted(kFlipLdrMap) ? &maps->flip_ldr : nullptr);
  clock.Lap(&MetricsSeconds::flip_ldr);
  r.flip_hdr = FlipHdr(ref, tst, flip, wanted(kFlipHdrMap) ? &maps->flip_hdr : nullptr);
  clock.Lap(&MetricsSeconds::flip_hdr);

  if (wanted(kAbsoluteErrorMap)) maps->absolute_error = AbsoluteErrorMap(ref, tst, mask);
  if (wanted(kRelativeErrorMap)) {
    maps->relative_error = RelativeErrorMap(ref, tst, p.relative_epsilon, mask);
  }
  clock.Lap(&MetricsSeconds::maps);
  return r;
}

nlohmann::json MetricsToJson(const MetricsReport& r) {
  nlohmann::json j;
  j["schema"] = "shadefit.metrics/1";
  j["width"] = r.width;
  j["height"] = r.height;
  j["masked"] = r.masked;
  j["valid_pixels"] = r.valid_pixels;
  j["parameters"] = {{"exposure_stops", r.exposure_stops},
                     {"ppd", r.ppd},
                     {"relative_epsilon", r.relative_epsilon},
                     {"itp_white_luminance", r.itp_white_luminance}};
  j["linear"] = {{"rmse", r.rmse},
                 {"relative_rmse", r.relative_rmse},
                 {"log_rmse", r.log_rmse},
                 {"mae", r.mae}};
  j["display"] = {
      {"psnr_db", Number(r.psnr)},
      {"ssim_luminance", r.ssim_luminance.mean},
      {"ssim_rgb", {{"mean", r.ssim_rgb.mean}, {"channels", r.ssim_rgb.channel_means}}},
      {"ssim_pooled_pixels", r.ssim_luminance.pooled_pixels},
      {"ms_ssim",
       {{"value", r.ms_ssim.value},
        {"scales_used", r.ms_ssim.scales_used},
        {"contrast_structure", r.ms_ssim.contrast_structure},
        {"luminance", r.ms_ssim.luminance}}}};
  j["ciede2000"] = {{"mean", r.ciede2000.mean}, {"p95", r.ciede2000.p95}, {"max", r.ciede2000.max}};
  j["delta_e_itp"] = {
      {"mean", r.delta_e_itp.mean}, {"p95", r.delta_e_itp.p95}, {"max", r.delta_e_itp.max}};
  j["flip_ldr"] = FlipJson(r.flip_ldr, false);
  j["flip_hdr"] = FlipJson(r.flip_hdr, true);
  return j;
}

void WriteMetricMaps(const MetricsMaps& maps, const std::string& directory) {
  if (!std::filesystem::is_directory(directory)) {
    throw Error(directory, "maps", "directory does not exist");
  }
  const auto path = [&](const char* name) {
    return (std::filesystem::path(directory) / name).string();
  };
  FalseColorParameters viridis;
  WriteFalseColorPng(path("abs_error.png"), maps.absolute_error, viridis);
  WriteFalseColorPng(path("rel_error.png"), maps.relative_error, viridis);
  WriteFalseColorPng(path("ciede2000.png"), maps.ciede2000, viridis);
  WriteFalseColorPng(path("delta_e_itp.png"), maps.delta_e_itp, viridis);
  FalseColorParameters unit = viridis;
  unit.min = 0.0;
  unit.max = 1.0;
  WriteFalseColorPng(path("ssim.png"), maps.ssim, unit);
  FalseColorParameters magma = unit;
  magma.color_map = ColorMap::kMagma;
  WriteFalseColorPng(path("flip_ldr.png"), maps.flip_ldr, magma);
  WriteFalseColorPng(path("flip_hdr.png"), maps.flip_hdr, magma);
}

}  // namespace shadefit::metrics
