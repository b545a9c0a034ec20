#include "shadefit/metrics/report.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "flip_map.h"
#include "internal.h"
#include "kept_inputs.h"
#include "reference_cache.h"
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

// A rectangle of the frame.
struct Window {
  int x = 0, y = 0, width = 0, height = 0;
};

// MS-SSIM's coarsest scale is 2^4 frame pixels: a window whose corner lies on a multiple of it
// has a pyramid whose pixels are the frame pyramid's. (Its scale count, which MsSsim takes from
// the image's size, is then the frame's too: the mask limits it first, as a scale with a window
// inside the mask has one inside the window.)
constexpr int kPyramidStep = 16;

// Where the masked metrics read: the mask's bounding box widened by what the filters read around
// a pixel (FLIP's clamp at the frame's edges, SSIM's 11 x 11 window), clipped to the frame, its
// corner moved down to a multiple of kPyramidStep. None when that is the whole frame, or when the
// observer is not one FLIP accepts (FLIP reports it on the whole frame, as without a window).
std::optional<Window> MaskWindow(const Image& mask, double ppd, int ssim_window) {
  if (!(std::isfinite(ppd) && ppd > 0.0)) return std::nullopt;
  const double reach = std::max<double>(internal::SideRadius(ppd), ssim_window);
  if (!(reach < std::max(mask.width, mask.height))) return std::nullopt;
  const int margin = static_cast<int>(reach);
  int x0 = mask.width, y0 = mask.height, x1 = 0, y1 = 0;  // The box: [x0, x1) x [y0, y1).
  for (int y = 0; y < mask.height; ++y) {
    for (int x = 0; x < mask.width; ++x) {
      if (!(mask.data[static_cast<std::size_t>(y) * mask.width + x] > 0.5f)) continue;
      x0 = std::min(x0, x);
      y0 = std::min(y0, y);
      x1 = std::max(x1, x + 1);
      y1 = std::max(y1, y + 1);
    }
  }
  if (x0 >= x1) return std::nullopt;  // No valid pixel (ValidateInputs refuses such a mask).
  x0 = std::max(0, x0 - margin) / kPyramidStep * kPyramidStep;
  y0 = std::max(0, y0 - margin) / kPyramidStep * kPyramidStep;
  x1 = std::min(mask.width, x1 + margin);
  y1 = std::min(mask.height, y1 + margin);
  if (x1 - x0 == mask.width && y1 - y0 == mask.height) return std::nullopt;
  return Window{x0, y0, x1 - x0, y1 - y0};
}

Image Cut(const Image& image, const Window& w) {
  Image out(w.width, w.height, image.channels);
  const std::size_t row = static_cast<std::size_t>(w.width) * image.channels;
  for (int y = 0; y < w.height; ++y) {
    const float* from =
        &image.data[(static_cast<std::size_t>(w.y + y) * image.width + w.x) * image.channels];
    std::copy(from, from + row, &out.data[y * row]);
  }
  return out;
}

// A point-wise map of the window in a frame of NaN, which such maps hold outside the mask.
Image Uncut(const Image& map, const Window& w, int width, int height) {
  Image out(width, height, map.channels, std::numeric_limits<float>::quiet_NaN());
  const std::size_t row = static_cast<std::size_t>(w.width) * map.channels;
  for (int y = 0; y < w.height; ++y) {
    std::copy(&map.data[y * row], &map.data[y * row] + row,
              &out.data[(static_cast<std::size_t>(w.y + y) * width + w.x) * map.channels]);
  }
  return out;
}

// A kept point-wise map's statistics over `mask` (KeptTerms): what the metric's own summary
// (SummarizeMap) gives over the same values in the same order. Every pixel of the mask must hold
// a value (the map is NaN outside its call's mask).
internal::MapStatistics KeptMapStatistics(const Image& map, int width, int height,
                                          const Image* mask, const std::string& metric,
                                          const InputNames& names) {
  const std::string field = "kept." + metric;
  if (map.channels != 1 || map.width != width || map.height != height) {
    throw Error(names.reference, field,
                map.empty() ? std::string("the earlier call kept no such map")
                            : "the kept map is not a one-channel map of the mask's frame");
  }
  for (std::size_t i = 0; i < map.PixelCount(); ++i) {
    if (internal::IsValid(mask, i) && std::isnan(map.data[i])) {
      throw Error(names.reference, field,
                  "the kept map has no value at pixel (" + std::to_string(i % map.width) +
                      ", " + std::to_string(i / map.width) + ") of the mask");
    }
  }
  return internal::SummarizeMap(map, mask);
}

// The display encodings of a reference and a test image (for PSNR and SSIM: RGB; for SSIM's
// luminance and MS-SSIM: luminance).
struct Encoded {
  Image ref, tst;
};

// The reference's display encoding (RGB, or luminance), from `cache` when it holds it: every fit
// of a study evaluated under one lighting encodes the same reference. `pixels`: HashPixels(ref).
Image ReferenceDisplay(ReferenceCache* cache, std::uint64_t pixels, const Image& ref, float stops,
                       bool luminance) {
  const auto encode = [&] { return DisplayEncode(luminance ? Luminance(ref) : ref, stops); };
  if (cache == nullptr) return encode();
  const ReferenceCache::Impl::Key key{ReferenceCache::Impl::Kind::kDisplay, pixels, 0,
                                      {stops, luminance ? 1.0 : 0.0, 0.0}};
  return *FindOrMake<Image>(cache, key, encode,
                            [](const Image& im) { return im.data.size() * sizeof(float); });
}

Encoded EncodeRgb(ReferenceCache* cache, std::uint64_t pixels, const Image& ref, const Image& tst,
                  float stops) {
  return {ReferenceDisplay(cache, pixels, ref, stops, false), DisplayEncode(tst, stops)};
}

Encoded EncodeLuminance(ReferenceCache* cache, std::uint64_t pixels, const Image& ref,
                        const Image& tst, float stops) {
  return {ReferenceDisplay(cache, pixels, ref, stops, true), DisplayEncode(Luminance(tst), stops)};
}

// Whether a later call (its window at x0, y0, images `tst` and its parameters) can take from
// `kept`: the same display exposure and observer, its window inside the keeping call's, and its
// test's pixels the keeping call's test's, bit for bit.
bool SameTest(const internal::KeptInputs& kept, int x0, int y0, const Image& tst,
              const MetricsParameters& p) {
  if (kept.exposure_stops != p.exposure_stops || kept.flip.ppd != p.ppd) return false;
  const int dx = x0 - kept.x0, dy = y0 - kept.y0;
  if (dx < 0 || dy < 0 || dx + tst.width > kept.tst.width || dy + tst.height > kept.tst.height ||
      kept.tst.channels != tst.channels) {
    return false;
  }
  const std::size_t row = static_cast<std::size_t>(tst.width) * tst.channels;
  for (int y = 0; y < tst.height; ++y) {
    const float* own = &tst.data[y * row];
    const float* theirs =
        &kept.tst.data[(static_cast<std::size_t>(dy + y) * kept.tst.width + dx) * tst.channels];
    if (std::memcmp(own, theirs, row * sizeof(float)) != 0) return false;
  }
  return true;
}

// A later call's encodings from the keeping call's (`ref_kept`, `tst_kept`: one of KeptInputs'
// pairs): its test's are the kept test's (SameTest), and at each pixel its reference's are the
// kept reference's where its reference has the kept reference's bits there, else the test's where
// it has the test's (a pixel patched with the test's values). Empty when a reference pixel is
// neither: the caller encodes then.
std::optional<Encoded> EncodedFromKept(const internal::KeptInputs& kept, int x0, int y0,
                                       const Image& ref, const Image& tst, const Image& ref_kept,
                                       const Image& tst_kept) {
  const int w = ref.width, h = ref.height, c = ref_kept.channels;
  const int dx = x0 - kept.x0, dy = y0 - kept.y0;
  Encoded out{Image(w, h, c), Image(w, h, c)};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      const std::size_t k = static_cast<std::size_t>(dy + y) * kept.ref.width + dx + x;
      const float* r = &ref.data[3 * i];
      const float* from = nullptr;
      if (std::memcmp(r, &kept.ref.data[3 * k], 3 * sizeof(float)) == 0) {
        from = &ref_kept.data[c * k];
      } else if (std::memcmp(r, &tst.data[3 * i], 3 * sizeof(float)) == 0) {
        from = &tst_kept.data[c * k];
      } else {
        return std::nullopt;
      }
      std::copy_n(from, c, &out.ref.data[c * i]);
      std::copy_n(&tst_kept.data[c * k], c, &out.tst.data[c * i]);
    }
  }
  return out;
}

}  // namespace

MetricsReport ComputeMetrics(const Image& reference, const Image& test, const Image* mask,
                             const MetricsParameters& p, MetricsMaps* maps) {
  MetricClock clock(p.seconds);
  ValidateInputs(reference, test, mask, 3, p.names);
  // Every metric below reads windows or clipped encodings of these: checked once, here.
  const internal::CheckedInputs checked;
  const auto wanted = [&](MetricMap map) { return maps != nullptr && (p.maps_wanted & map) != 0; };
  // RGB: the inputs themselves, or their first three channels.
  Image ref_rgb, tst_rgb;
  if (reference.channels != 3) ref_rgb = reference.Channels(0, 3);
  if (test.channels != 3) tst_rgb = test.Channels(0, 3);
  const Image& ref = reference.channels == 3 ? reference : ref_rgb;
  const Image& tst = test.channels == 3 ? test : tst_rgb;

  if (p.keep) *p.keep = {};  // Nothing of an earlier call's, whatever this one throws.
  MetricsReport r;
  r.width = ref.width;
  r.height = ref.height;
  r.masked = mask != nullptr;
  r.valid_pixels = CountValidPixels(mask, ref.width, ref.height);
  r.exposure_stops = p.exposure_stops;
  r.ppd = p.ppd;
  r.relative_epsilon = p.relative_epsilon;
  r.itp_white_luminance = p.itp_white_luminance;

  // Every metric pools over the mask's pixels alone and reads the frame only around them, summing
  // in the frame's order: on the window around the mask (MaskWindow) each gives the frame's bits,
  // at a fraction of the cost when the object is small in its frame (a photograph's). Not when a
  // map that shows pixels beyond the mask is wanted (SSIM's, FLIP's), nor when the frame is
  // smaller than an SSIM window (the error then names the frame's size).
  SsimParameters ssim;
  ssim.data_range = 1.0;
  const int ssim_window = 2 * ssim.radius + 1;
  std::optional<Window> window;
  if (mask != nullptr && !wanted(kSsimMap) && !wanted(kFlipLdrMap) && !wanted(kFlipHdrMap) &&
      ref.width >= ssim_window && ref.height >= ssim_window) {
    window = MaskWindow(*mask, p.ppd, ssim_window);
  }
  Image cut_ref, cut_tst, cut_mask;
  if (window) {
    cut_ref = Cut(ref, *window);
    cut_tst = Cut(tst, *window);
    cut_mask = Cut(*mask, *window);
  }
  const Image& ref_part = window ? cut_ref : ref;
  const Image& tst_part = window ? cut_tst : tst;
  const Image* mask_part = window ? &cut_mask : mask;
  // A point-wise map of the window, in the frame.
  const auto frame_map = [&](Image&& map) {
    return window ? Uncut(map, *window, ref.width, ref.height) : std::move(map);
  };

  // The part's corner in the frame, and what a keeping call left for this one (KeptTerms::inputs)
  // when its test is this one's.
  const int x0 = window ? window->x : 0, y0 = window ? window->y : 0;
  const internal::KeptInputs* from =
      p.keep == nullptr && p.kept != nullptr && p.kept->inputs != nullptr &&
              SameTest(*p.kept->inputs, x0, y0, tst_part, p)
          ? p.kept->inputs.get()
          : nullptr;
  std::shared_ptr<internal::KeptInputs> keep_inputs;
  if (p.keep != nullptr) keep_inputs = std::make_shared<internal::KeptInputs>();

  const PixelMetricParameters pixel{mask_part, p.relative_epsilon};
  r.rmse = Rmse(ref_part, tst_part, pixel);
  r.relative_rmse = RelativeRmse(ref_part, tst_part, pixel);
  r.log_rmse = LogRmse(ref_part, tst_part, pixel);
  r.mae = MeanAbsoluteError(ref_part, tst_part, pixel);
  // Display-encoded values in [0, 1], shared by PSNR and the structural metrics.
  std::optional<Encoded> rgb_encoded;
  if (from) {
    rgb_encoded = EncodedFromKept(*from, x0, y0, ref_part, tst_part, from->ref_display,
                                  from->tst_display);
  }
  // The part's pixels identify the reference's encodings in the cache (a window of it has its
  // own).
  const std::uint64_t ref_part_hash = p.reference_cache ? HashPixels(ref_part) : 0;
  if (!rgb_encoded) {
    rgb_encoded = EncodeRgb(p.reference_cache, ref_part_hash, ref_part, tst_part, p.exposure_stops);
  }
  const Image& ref_display = rgb_encoded->ref;
  const Image& tst_display = rgb_encoded->tst;
  r.psnr = internal::PsnrOfEncoded(ref_display, tst_display, mask_part);
  clock.Lap(&MetricsSeconds::pixel);

  ssim.mask = mask_part;
  std::optional<Encoded> y_encoded;
  if (from) y_encoded = EncodedFromKept(*from, x0, y0, ref_part, tst_part, from->ref_y, from->tst_y);
  if (!y_encoded) {
    y_encoded =
        EncodeLuminance(p.reference_cache, ref_part_hash, ref_part, tst_part, p.exposure_stops);
  }
  const Image& ref_y = y_encoded->ref;
  const Image& tst_y = y_encoded->tst;
  Image ssim_map;
  try {
    // SSIM of the luminance is MS-SSIM's first scale (internal::MsSsimAndSsim), unless its map is
    // wanted. Ssim's errors come first, as when it ran first: the same checks, in MsSsim's order.
    MsSsimParameters ms;
    ms.ssim = ssim;
    // Kept terms (KeptTerms) are placed in the frame by the window's corner.
    internal::SsimReuse luminance{x0, y0}, rgb = luminance;
    if (p.keep) {
      luminance.keep = &p.keep->ssim.luminance;
      rgb.keep = &p.keep->ssim.rgb;
    } else if (p.kept) {
      luminance.from = &p.kept->ssim.luminance;
      rgb.from = &p.kept->ssim.rgb;
    }
    if (wanted(kSsimMap)) {
      r.ssim_luminance = Ssim(ref_y, tst_y, ssim, &ssim_map);
      r.ms_ssim = internal::MsSsimAndSsim(ref_y, tst_y, ms, nullptr, luminance);
    } else {
      r.ms_ssim = internal::MsSsimAndSsim(ref_y, tst_y, ms, &r.ssim_luminance, luminance);
    }
    r.ssim_rgb = internal::SsimReusing(ref_display, tst_display, ssim, rgb);
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
  if (wanted(kSsimMap)) maps->ssim = std::move(ssim_map);  // Never of a window (above).
  clock.Lap(&MetricsSeconds::ssim);

  // The point-wise colour differences: computed (their maps kept, or given, where asked for), or
  // an earlier call's kept map's statistics over this mask (KeptTerms).
  const auto point_wise = [&](auto compute, Image KeptTerms::*kept_map, MetricMap bit,
                              Image MetricsMaps::*map_out, const char* name, auto* result) {
    if (p.kept != nullptr && p.keep == nullptr) {
      const internal::MapStatistics s =
          KeptMapStatistics(p.kept->*kept_map, r.width, r.height, mask, name, p.names);
      *result = {s.mean, s.p95, s.max};
      return;
    }
    Image map;
    *result = compute(wanted(bit) || p.keep != nullptr ? &map : nullptr);
    if (p.keep != nullptr) p.keep->*kept_map = frame_map(Image(map));
    if (wanted(bit)) maps->*map_out = frame_map(std::move(map));
  };
  DeltaE2000Parameters de;
  de.exposure_stops = p.exposure_stops;
  de.mask = mask_part;
  de.reference_cache = p.reference_cache;
  point_wise([&](Image* map) { return DeltaE2000(ref_part, tst_part, de, map); },
             &KeptTerms::ciede2000, kCiede2000Map, &MetricsMaps::ciede2000, "ciede2000",
             &r.ciede2000);
  clock.Lap(&MetricsSeconds::ciede2000);
  DeltaEItpParameters itp;
  itp.white_luminance = p.itp_white_luminance;
  itp.mask = mask_part;
  itp.reference_cache = p.reference_cache;
  point_wise([&](Image* map) { return DeltaEItp(ref_part, tst_part, itp, map); },
             &KeptTerms::delta_e_itp, kDeltaEItpMap, &MetricsMaps::delta_e_itp, "delta_e_itp",
             &r.delta_e_itp);
  clock.Lap(&MetricsSeconds::delta_e_itp);

  FlipParameters flip;
  flip.ppd = p.ppd;
  flip.mask = mask_part;
  flip.reference_cache = p.reference_cache;
  // The test's halves: taken from a keeping call's (`from`) or kept for a later one.
  const internal::FlipReuse flip_reuse{x0, y0, keep_inputs ? &keep_inputs->flip : nullptr,
                                       from ? &from->flip : nullptr};
  r.flip_ldr = internal::FlipLdr(ExposeAndClip(ref_part, p.exposure_stops),
                                 ExposeAndClip(tst_part, p.exposure_stops), flip,
                                 wanted(kFlipLdrMap) ? &maps->flip_ldr : nullptr, flip_reuse);
  clock.Lap(&MetricsSeconds::flip_ldr);
  r.flip_hdr = internal::FlipHdr(ref_part, tst_part, flip,
                                 wanted(kFlipHdrMap) ? &maps->flip_hdr : nullptr, nullptr,
                                 flip_reuse);
  clock.Lap(&MetricsSeconds::flip_hdr);

  if (wanted(kAbsoluteErrorMap)) maps->absolute_error = AbsoluteErrorMap(ref, tst, mask);
  if (wanted(kRelativeErrorMap)) {
    maps->relative_error = RelativeErrorMap(ref, tst, p.relative_epsilon, mask);
  }
  clock.Lap(&MetricsSeconds::maps);
  if (keep_inputs) {
    keep_inputs->x0 = x0;
    keep_inputs->y0 = y0;
    keep_inputs->exposure_stops = p.exposure_stops;
    keep_inputs->ref = window ? std::move(cut_ref) : ref;
    keep_inputs->tst = window ? std::move(cut_tst) : tst;
    keep_inputs->ref_display = std::move(rgb_encoded->ref);
    keep_inputs->tst_display = std::move(rgb_encoded->tst);
    keep_inputs->ref_y = std::move(y_encoded->ref);
    keep_inputs->tst_y = std::move(y_encoded->tst);
    p.keep->inputs = std::move(keep_inputs);
  }
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
