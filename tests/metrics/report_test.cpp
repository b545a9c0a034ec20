// The combined report, its JSON, and the false-colour maps.
#include "shadefit/metrics/report.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/metrics/false_color.h"
#include "shadefit/metrics/pixel_metrics.h"
#include "../../metrics/src/kept_inputs.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

namespace fs = std::filesystem;

TEST(ReportTest, IdenticalImages) {
  const Image a = testing::HdrScene(64, 64);
  const MetricsReport r = ComputeMetrics(a, a, nullptr);
  EXPECT_EQ(r.rmse, 0.0);
  EXPECT_EQ(r.mae, 0.0);
  EXPECT_TRUE(std::isinf(r.psnr));
  EXPECT_NEAR(r.ssim_luminance.mean, 1.0, 1e-12);
  EXPECT_NEAR(r.ssim_rgb.mean, 1.0, 1e-12);
  EXPECT_NEAR(r.ms_ssim.value, 1.0, 1e-12);
  EXPECT_EQ(r.ciede2000.mean, 0.0);
  EXPECT_EQ(r.delta_e_itp.mean, 0.0);
  EXPECT_EQ(r.flip_ldr.mean, 0.0);
  EXPECT_EQ(r.flip_hdr.mean, 0.0);
  const nlohmann::json j = MetricsToJson(r);
  EXPECT_TRUE(j["display"]["psnr_db"].is_null());  // +inf has no JSON number.
}

TEST(ReportTest, JsonHasEveryDocumentedField) {
  const Image a = testing::HdrScene(64, 64);
  const Image b = testing::HdrDistorted(a, 0.1f, 2);
  Image mask(64, 64, 1, 1.0f);
  mask.at(0, 0, 0) = 0.0f;
  MetricsMaps maps;
  const MetricsReport r = ComputeMetrics(a, b, &mask, {}, &maps);
  EXPECT_EQ(r.valid_pixels, 64u * 64u - 1u);
  const nlohmann::json j = MetricsToJson(r);
  EXPECT_EQ(j["schema"], "shadefit.metrics/1");
  for (const char* key : {"width", "height", "masked", "valid_pixels", "parameters", "linear",
                          "display", "ciede2000", "delta_e_itp", "flip_ldr", "flip_hdr"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  for (const char* key : {"mean", "p95", "max"}) {
    EXPECT_GT(j["delta_e_itp"][key].get<double>(), 0.0) << key;
  }
  EXPECT_EQ(j["parameters"]["itp_white_luminance"].get<double>(), 100.0);
  for (const char* key : {"rmse", "relative_rmse", "log_rmse", "mae"}) {
    EXPECT_GT(j["linear"][key].get<double>(), 0.0) << key;
  }
  for (const char* key :
       {"psnr_db", "ssim_luminance", "ssim_rgb", "ssim_pooled_pixels", "ms_ssim"}) {
    EXPECT_TRUE(j["display"].contains(key)) << key;
  }
  for (const char* key :
       {"mean", "median", "p95", "p99", "max", "weighted_median", "weighted_q1", "weighted_q3",
        "histogram", "start_exposure", "stop_exposure", "num_exposures"}) {
    EXPECT_TRUE(j["flip_hdr"].contains(key)) << key;
  }
  EXPECT_TRUE(std::isnan(maps.absolute_error.at(0, 0, 0)));

  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "metrics_maps";
  fs::create_directories(dir);
  WriteMetricMaps(maps, dir.string());
  for (const char* name : {"abs_error.png", "rel_error.png", "ciede2000.png", "delta_e_itp.png",
                           "ssim.png", "flip_ldr.png", "flip_hdr.png"}) {
    const Image png = ReadImage((dir / name).string());
    EXPECT_EQ(png.height, 64) << name;
    EXPECT_GT(png.width, 64 + 16) << name;  // Map plus the colour bar strip.
  }
}

TEST(ReportTest, ErrorsNameTheFile) {
  const Image a(32, 32, 3, 0.5f), b(16, 32, 3, 0.5f);
  MetricsParameters p;
  p.names = {"ref.exr", "test.exr", "m.png"};
  try {
    ComputeMetrics(a, b, nullptr, p);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "test.exr: resolution: 16x32 differs from the reference's 32x32 (ref.exr)");
  }
  const Image empty(32, 32, 1, 0.0f);
  try {
    ComputeMetrics(a, a, &empty, p);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "m.png: pixels: empty mask (no pixel > 0.5)");
  }
}

// ComputeMetrics scans its inputs' values once (metrics/src/internal.h, CheckedInputs): the
// metrics inside it take windows and clipped encodings of them and do not scan again. That ends
// with the call, thrown or not: a metric called afterwards on the same thread still refuses a NaN
// and an empty mask.
TEST(ReportTest, InputsAreScannedOnceAndOnlyInsideTheCall) {
  const Image ref(32, 32, 3, 0.5f);
  Image nan_test = ref;
  nan_test.at(3, 4, 1) = std::numeric_limits<float>::quiet_NaN();
  const Image empty_mask(32, 32, 1, 0.0f);
  const PixelMetricParameters empty{&empty_mask};
  MetricsParameters p;
  EXPECT_THROW(ComputeMetrics(ref, nan_test, nullptr, p), Error);
  ComputeMetrics(ref, ref, nullptr, p);  // Ends normally.
  EXPECT_THROW(Rmse(ref, nan_test), Error);
  EXPECT_THROW(Rmse(ref, ref, empty), Error);
  // Throws from inside, after its own check: SSIM's window does not fit a 4 x 4 frame.
  const Image small(4, 4, 3, 0.5f);
  EXPECT_THROW(ComputeMetrics(small, small, nullptr, p), Error);
  EXPECT_THROW(Rmse(ref, nan_test), Error);
  EXPECT_THROW(Rmse(ref, ref, empty), Error);
}

// A mask for the window tests: an ellipse (centre, radii); when `scattered`, with holes and with
// single pixels over the whole frame.
Image EllipseMask(int w, int h, double cx, double cy, double rx, double ry, bool scattered) {
  Image mask(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double u = (x + 0.5 - cx) / rx, v = (y + 0.5 - cy) / ry;
      const bool hole = scattered && testing::HashNoise(x, y, 0, 7) < -0.995f;
      const bool inside = u * u + v * v <= 1.0 && !hole;
      const bool speck = scattered && testing::HashNoise(x, y, 1, 9) > 0.995f;
      mask.at(x, y, 0) = inside || speck ? 1.0f : 0.0f;
    }
  }
  return mask;
}

// ComputeMetrics works on a window around the mask (metrics/src/report.cpp, MaskWindow): it must
// give the bits of each metric computed on the whole frame, whichever edges the mask touches and
// whatever the observer's filter widths. The expected values call the metric functions on the
// frame, as ComputeMetrics did before it had a window.
TEST(ReportTest, WindowAroundTheMaskGivesTheFramesValues) {
  struct Case {
    const char* name;
    int w, h;
    double cx, cy, rx, ry;
    bool scattered;
    double ppd;
    float exposure_stops;
    int min_scales;  // MS-SSIM's scales at least (a pyramid for the window to keep aligned).
  };
  const Case cases[] = {
      {"centre", 203, 161, 97.3, 83.1, 41.0, 30.0, false, 67.0, 0.0f, 3},
      {"top-left edges", 160, 120, 10.0, 6.0, 55.0, 40.0, false, 67.0, -1.0f, 2},
      {"bottom-right edges", 150, 170, 140.0, 165.0, 60.0, 45.0, false, 30.0, 0.5f, 2},
      {"narrow observer", 256, 192, 131.0, 95.0, 70.0, 62.0, false, 8.0, 0.0f, 3},
      {"scattered", 220, 180, 120.0, 90.0, 35.0, 28.0, true, 67.0, 0.0f, 1},
      {"wide observer", 230, 200, 110.0, 96.0, 60.0, 50.0, false, 120.0, 0.0f, 3},
      {"small object", 240, 240, 171.0, 57.0, 12.0, 9.0, false, 67.0, 0.0f, 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Image ref = testing::HdrScene(c.w, c.h);
    const Image tst = testing::HdrDistorted(ref, 0.15f, 3);
    const Image mask = EllipseMask(c.w, c.h, c.cx, c.cy, c.rx, c.ry, c.scattered);

    MetricsReport expected;
    expected.width = c.w;
    expected.height = c.h;
    expected.masked = true;
    expected.valid_pixels = CountValidPixels(&mask, c.w, c.h);
    expected.exposure_stops = c.exposure_stops;
    expected.ppd = c.ppd;
    const PixelMetricParameters pixel{&mask, expected.relative_epsilon};
    expected.rmse = Rmse(ref, tst, pixel);
    expected.relative_rmse = RelativeRmse(ref, tst, pixel);
    expected.log_rmse = LogRmse(ref, tst, pixel);
    expected.mae = MeanAbsoluteError(ref, tst, pixel);
    expected.psnr = Psnr(ref, tst, {c.exposure_stops, &mask});
    SsimParameters ssim;
    ssim.mask = &mask;
    const Image ref_y = DisplayEncode(Luminance(ref), c.exposure_stops);
    const Image tst_y = DisplayEncode(Luminance(tst), c.exposure_stops);
    expected.ssim_luminance = Ssim(ref_y, tst_y, ssim);
    expected.ssim_rgb =
        Ssim(DisplayEncode(ref, c.exposure_stops), DisplayEncode(tst, c.exposure_stops), ssim);
    MsSsimParameters ms;
    ms.ssim = ssim;
    expected.ms_ssim = MsSsim(ref_y, tst_y, ms);
    DeltaE2000Parameters de;
    de.exposure_stops = c.exposure_stops;
    de.mask = &mask;
    Image ciede2000_map, itp_map;
    expected.ciede2000 = DeltaE2000(ref, tst, de, &ciede2000_map);
    DeltaEItpParameters itp;
    itp.mask = &mask;
    expected.delta_e_itp = DeltaEItp(ref, tst, itp, &itp_map);
    FlipParameters flip;
    flip.ppd = c.ppd;
    flip.mask = &mask;
    expected.flip_ldr = FlipLdr(ExposeAndClip(ref, c.exposure_stops),
                                ExposeAndClip(tst, c.exposure_stops), flip);
    expected.flip_hdr = FlipHdr(ref, tst, flip);
    EXPECT_GE(expected.ms_ssim.scales_used, c.min_scales);

    MetricsParameters p;
    p.ppd = c.ppd;
    p.exposure_stops = c.exposure_stops;
    p.maps_wanted = kAbsoluteErrorMap | kCiede2000Map | kDeltaEItpMap;
    ReferenceCache cache(64 << 20);
    p.reference_cache = &cache;
    for (int call = 0; call < 2; ++call) {  // The second finds the reference's FLIP halves kept.
      MetricsMaps maps;
      const MetricsReport got = ComputeMetrics(ref, tst, &mask, p, &maps);
      EXPECT_EQ(MetricsToJson(got).dump(), MetricsToJson(expected).dump());
      ASSERT_EQ(maps.ciede2000.width, c.w);
      ASSERT_EQ(maps.delta_e_itp.height, c.h);
      for (std::size_t i = 0; i < mask.PixelCount(); ++i) {
        if (mask.data[i] > 0.5f) {
          ASSERT_EQ(maps.ciede2000.data[i], ciede2000_map.data[i]) << i;
          ASSERT_EQ(maps.delta_e_itp.data[i], itp_map.data[i]) << i;
        } else {
          ASSERT_TRUE(std::isnan(maps.ciede2000.data[i])) << i;
          ASSERT_TRUE(std::isnan(maps.delta_e_itp.data[i])) << i;
        }
      }
    }
    EXPECT_GT(cache.stats().hits, 0u);
  }
}

// A study's measured pass compares the same test with a reference patched outside its pixels
// (the covered pixels less a shadow's edge and a cut-off top and left, so that its window around
// the mask has another corner); pooled from the covered pass's kept terms (or a whole-frame
// pass's), its numbers are those it
// computes without them. The terms are read (changed values change the numbers: CIEDE2000's and
// Delta E_ITP's maps, SSIM's luminance and RGB terms at the first scale, MS-SSIM's at a coarser
// one); SSIM computes where a term is missing; point-wise maps that miss a pixel are refused.
// A covered pass's images and mask, and its measured pass's: the covered pixels less a curved
// band through the object (the "shadow edge"), its top rows and its left columns, the reference
// patched with the test's values there.
struct TwoPasses {
  static constexpr int w = 420, h = 330;
  Image ref, tst, covered, measured, patched;
};

TwoPasses MakeTwoPasses() {
  TwoPasses t;
  const int w = TwoPasses::w, h = TwoPasses::h;
  t.ref = testing::HdrScene(w, h);
  t.tst = testing::HdrDistorted(t.ref, 0.2f, 7);
  t.covered = EllipseMask(w, h, 220.0, 180.0, 125.0, 100.0, false);
  t.measured = t.covered;
  t.patched = t.ref;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double edge = 0.002 * (x - 220.0) * (x - 220.0) + 255.0;
      if (t.covered.at(x, y, 0) > 0.5f && (std::abs(y - edge) < 3.0 || y < 120 || x < 140)) {
        t.measured.at(x, y, 0) = 0.0f;
        for (int c = 0; c < 3; ++c) t.patched.at(x, y, c) = t.tst.at(x, y, c);
      }
    }
  }
  return t;
}

TEST(ReportTest, KeptTermsGiveASecondPassItsOwnNumbers) {
  const int w = TwoPasses::w, h = TwoPasses::h;
  const TwoPasses two = MakeTwoPasses();
  const Image &ref = two.ref, &tst = two.tst, &covered = two.covered, &measured = two.measured,
              &patched = two.patched;
  MetricsParameters p;
  p.exposure_stops = -0.5f;
  KeptTerms kept;
  MetricsParameters keeping = p;
  keeping.keep = &kept;
  EXPECT_EQ(MetricsToJson(ComputeMetrics(ref, tst, &covered, keeping)).dump(),
            MetricsToJson(ComputeMetrics(ref, tst, &covered, p)).dump());
  ASSERT_GE(kept.ssim.luminance.size(), 3u);
  ASSERT_EQ(kept.ssim.rgb.size(), 3u);

  const MetricsReport own = ComputeMetrics(patched, tst, &measured, p);
  ASSERT_GE(own.ms_ssim.scales_used, 3);
  MetricsParameters reuse = p;
  reuse.kept = &kept;
  MetricsMaps maps;
  const MetricsReport got = ComputeMetrics(patched, tst, &measured, reuse, &maps);
  EXPECT_EQ(MetricsToJson(got).dump(), MetricsToJson(own).dump());
  EXPECT_TRUE(maps.ciede2000.empty());
  {
    KeptTerms frame;
    keeping.keep = &frame;
    ComputeMetrics(ref, tst, nullptr, keeping);
    reuse.kept = &frame;
    EXPECT_EQ(MetricsToJson(ComputeMetrics(patched, tst, &measured, reuse)).dump(),
              MetricsToJson(own).dump());
    keeping.keep = &kept;
    reuse.kept = &kept;
  }

  // The numbers come from the kept terms.
  KeptTerms changed = kept;
  const std::size_t centre = static_cast<std::size_t>(180) * w + 220;
  ASSERT_GT(measured.data[centre], 0.5f);
  changed.ciede2000.data[centre] = 1000.0f;
  changed.delta_e_itp.data[centre] = 2000.0f;
  const auto set_all = [](std::vector<double>& terms, double value) {
    for (double& t : terms) t = std::isnan(t) ? t : value;
  };
  set_all(changed.ssim.luminance[0].ssim, 0.5);
  set_all(changed.ssim.rgb[1].ssim, 0.25);
  set_all(changed.ssim.luminance[2].cs, 0.375);
  reuse.kept = &changed;
  const MetricsReport moved = ComputeMetrics(patched, tst, &measured, reuse);
  EXPECT_EQ(moved.ciede2000.max, 1000.0);
  EXPECT_EQ(moved.delta_e_itp.max, 2000.0);
  EXPECT_EQ(moved.ssim_luminance.mean, 0.5);
  EXPECT_EQ(moved.ssim_rgb.channel_means[1], 0.25);
  EXPECT_EQ(moved.ssim_rgb.channel_means[0], own.ssim_rgb.channel_means[0]);
  EXPECT_EQ(moved.ms_ssim.contrast_structure[2], 0.375);
  EXPECT_EQ(moved.ms_ssim.contrast_structure[1], own.ms_ssim.contrast_structure[1]);
  EXPECT_EQ(moved.rmse, own.rmse);

  // A pooled pixel without a kept SSIM term: that plane is computed.
  KeptTerms holed = kept;
  for (double& t : holed.ssim.rgb[2].ssim) t = std::numeric_limits<double>::quiet_NaN();
  set_all(holed.ssim.rgb[0].ssim, 0.75);
  reuse.kept = &holed;
  const MetricsReport refilled = ComputeMetrics(patched, tst, &measured, reuse);
  EXPECT_EQ(refilled.ssim_rgb.channel_means[2], own.ssim_rgb.channel_means[2]);
  EXPECT_EQ(refilled.ssim_rgb.channel_means[0], 0.75);

  // Point-wise maps of a smaller mask miss some of this one's pixels.
  const Image smaller = EllipseMask(w, h, 220.0, 180.0, 30.0, 20.0, false);
  KeptTerms partial;
  keeping.keep = &partial;
  ComputeMetrics(ref, tst, &smaller, keeping);
  reuse.kept = &partial;
  try {
    ComputeMetrics(patched, tst, &measured, reuse);
    ADD_FAILURE() << "maps that miss pixels of the mask were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("kept.ciede2000"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no value at pixel"), std::string::npos) << e.what();
  }
  const KeptTerms none;
  reuse.kept = &none;
  EXPECT_THROW(ComputeMetrics(patched, tst, &measured, reuse), Error);
}

// The keeping call's inputs (KeptTerms::inputs) give the measured pass its test's display
// encodings and FLIP halves (LDR-FLIP's, and HDR-FLIP's at an exposure both passes use), and its
// reference's encodings where its pixels are the kept reference's or the test's: the numbers and
// maps it computes without them. They are read (a changed kept value changes the numbers); not
// taken when the test's pixels differ from the kept test's; a reference pixel that is neither the
// kept reference's nor the test's is encoded.
TEST(ReportTest, KeptInputsGiveASecondPassItsOwnNumbers) {
  TwoPasses t = MakeTwoPasses();
  // A highlight at the centre (measured), the brightest covered pixel: both passes' HDR-FLIP
  // start at its exposure.
  for (int c = 0; c < 3; ++c) {
    t.ref.at(220, 180, c) = t.patched.at(220, 180, c) = 40.0f;
    t.tst.at(220, 180, c) = 30.0f;
  }
  const auto json_of = [](const MetricsReport& r) { return MetricsToJson(r).dump(); };
  MetricsParameters p;
  p.exposure_stops = -0.5f;
  p.maps_wanted = 0;
  KeptTerms kept;
  MetricsParameters keeping = p;
  keeping.keep = &kept;
  const MetricsReport covered = ComputeMetrics(t.ref, t.tst, &t.covered, keeping);
  ASSERT_TRUE(kept.inputs);
  const internal::KeptInputs& inputs = *kept.inputs;
  ASSERT_GT(inputs.x0 + inputs.y0, 0);  // A window around the mask.
  ASSERT_EQ(inputs.flip.halves.size(), 1u + covered.flip_hdr.num_exposures);
  const MetricsReport own = ComputeMetrics(t.patched, t.tst, &t.measured, p);
  ASSERT_EQ(own.flip_hdr.start_exposure, covered.flip_hdr.start_exposure);
  ASSERT_NE(own.flip_hdr.stop_exposure, covered.flip_hdr.stop_exposure);
  MetricsParameters reuse = p;
  reuse.kept = &kept;
  EXPECT_EQ(json_of(ComputeMetrics(t.patched, t.tst, &t.measured, reuse)), json_of(own));

  // The measured pass with kept inputs changed by `change` (the centre pixel, measured, is k).
  const int k = (180 - inputs.y0) * inputs.ref.width + (220 - inputs.x0);
  ASSERT_GT(t.measured.at(220, 180, 0), 0.5f);
  const auto changed = [&](auto change) {
    auto in = std::make_shared<internal::KeptInputs>(inputs);
    change(*in);
    KeptTerms terms = kept;
    terms.inputs = in;
    MetricsParameters q = p;
    q.kept = &terms;
    return ComputeMetrics(t.patched, t.tst, &t.measured, q);
  };
  const auto set_lab = [k](internal::FlipSide& side) { side.lab[k] = {{100.0f, 90.0f, -90.0f}}; };
  for (int c = 0; c < 3; ++c) {
    EXPECT_NE(changed([&](auto& in) { in.tst_display.data[3 * k + c] = 0.0f; }).psnr, own.psnr);
    EXPECT_NE(changed([&](auto& in) { in.ref_display.data[3 * k + c] = 0.0f; }).psnr, own.psnr);
  }
  EXPECT_NE(changed([&](auto& in) { set_lab(in.flip.halves[0].side); }).flip_ldr.max,
            own.flip_ldr.max);
  const MetricsReport hdr_moved = changed([&](auto& in) { set_lab(in.flip.halves[1].side); });
  EXPECT_NE(hdr_moved.flip_hdr.mean, own.flip_hdr.mean);
  EXPECT_EQ(hdr_moved.flip_ldr.mean, own.flip_ldr.mean);
  // Not taken when a test pixel differs (the kept encodings and halves changed with it).
  const MetricsReport other_test = changed([&](auto& in) {
    in.tst.data[3 * k] += 0.25f;
    in.tst_display.data[3 * k] = 1.0f;
    set_lab(in.flip.halves[0].side);
    set_lab(in.flip.halves[1].side);
  });
  EXPECT_EQ(json_of(other_test), json_of(own));

  // Over the whole frame, with SSIM's map (it reads the patched pixels' encodings): the same map,
  // also with a reference pixel that is neither the kept reference's nor the test's.
  MetricsParameters whole = p;
  whole.maps_wanted = kSsimMap;
  KeptTerms frame;
  keeping = whole;
  keeping.keep = &frame;
  MetricsMaps unused;
  ComputeMetrics(t.ref, t.tst, &t.covered, keeping, &unused);
  ASSERT_TRUE(frame.inputs);
  ASSERT_EQ(frame.inputs->x0 + frame.inputs->y0, 0);
  Image third = t.patched;
  ASSERT_LT(t.measured.at(220, 100, 0), 0.5f);
  ASSERT_GT(t.covered.at(220, 100, 0), 0.5f);
  third.at(220, 100, 1) = 0.123f;
  for (const Image* patched : {static_cast<const Image*>(&t.patched), static_cast<const Image*>(&third)}) {
    MetricsMaps own_maps, got_maps;
    const MetricsReport own_whole = ComputeMetrics(*patched, t.tst, &t.measured, whole, &own_maps);
    MetricsParameters q = whole;
    q.kept = &frame;
    EXPECT_EQ(json_of(ComputeMetrics(*patched, t.tst, &t.measured, q, &got_maps)),
              json_of(own_whole));
    ASSERT_EQ(got_maps.ssim.data.size(), own_maps.ssim.data.size());
    EXPECT_TRUE(std::equal(got_maps.ssim.data.begin(), got_maps.ssim.data.end(),
                           own_maps.ssim.data.begin(),
                           [](float a, float b) { return a == b || (a != a && b != b); }));
  }
}

// The ReferenceCache tests' inputs: a reference, a test image, the reference with one pixel
// changed inside the masks below, and an elliptical mask.
struct CacheInputs {
  Image ref = testing::HdrScene(96, 80);
  Image tst = testing::HdrDistorted(ref, 0.15f, 5);
  Image other_ref = ref;
  Image mask = EllipseMask(96, 80, 47.0, 41.0, 30.0, 25.0, false);
  CacheInputs() { other_ref.at(40, 40, 1) *= 1.5f; }
};

// The reference's CIELAB (CIEDE2000) and ICtCp (Delta E_ITP) kept in a ReferenceCache give the
// numbers and maps of a call without one, and are found again only for the same reference pixels,
// mask and parameters: a call that changes any of them in turn, with one cache, must match a
// call without it.
TEST(ReferenceCacheTest, PointWiseHalvesAreKeptPerPixelsMaskAndParameters) {
  const CacheInputs in;
  const Image &ref = in.ref, &tst = in.tst, &other_ref = in.other_ref, &mask = in.mask;
  Image smaller = mask;
  for (int x = 0; x < 96; ++x) smaller.at(x, 41, 0) = 0.0f;  // A row shorter: other offsets.
  struct Call {
    const Image* reference;
    const Image* mask;
    float exposure_stops;
    double white_luminance;
  };
  const Call calls[] = {{&ref, &mask, 0.0f, 100.0},      {&ref, &mask, 0.0f, 100.0},
                        {&other_ref, &mask, 0.0f, 100.0}, {&ref, &smaller, 0.0f, 100.0},
                        {&ref, &mask, -1.0f, 203.0},     {&ref, nullptr, 0.0f, 100.0},
                        {&ref, &mask, 0.0f, 100.0}};
  ReferenceCache cache(64 << 20);
  for (const Call& c : calls) {
    DeltaE2000Parameters de;
    de.mask = c.mask;
    de.exposure_stops = c.exposure_stops;
    DeltaEItpParameters itp;
    itp.mask = c.mask;
    itp.white_luminance = c.white_luminance;
    Image de_map, itp_map, de_cached_map, itp_cached_map;
    const DeltaE2000Result de_plain = DeltaE2000(*c.reference, tst, de, &de_map);
    const DeltaEItpResult itp_plain = DeltaEItp(*c.reference, tst, itp, &itp_map);
    de.reference_cache = &cache;
    itp.reference_cache = &cache;
    const DeltaE2000Result de_cached = DeltaE2000(*c.reference, tst, de, &de_cached_map);
    const DeltaEItpResult itp_cached = DeltaEItp(*c.reference, tst, itp, &itp_cached_map);
    EXPECT_EQ(de_cached.mean, de_plain.mean);
    EXPECT_EQ(de_cached.p95, de_plain.p95);
    EXPECT_EQ(de_cached.max, de_plain.max);
    EXPECT_EQ(itp_cached.mean, itp_plain.mean);
    EXPECT_EQ(itp_cached.p95, itp_plain.p95);
    EXPECT_EQ(itp_cached.max, itp_plain.max);
    for (std::size_t i = 0; i < de_map.PixelCount(); ++i) {
      ASSERT_TRUE(de_cached_map.data[i] == de_map.data[i] ||
                  (std::isnan(de_cached_map.data[i]) && std::isnan(de_map.data[i])))
          << i;
      ASSERT_TRUE(itp_cached_map.data[i] == itp_map.data[i] ||
                  (std::isnan(itp_cached_map.data[i]) && std::isnan(itp_map.data[i])))
          << i;
    }
  }
  // The second call and the last found both halves; every other call made its own.
  const ReferenceCache::Stats stats = cache.stats();
  EXPECT_EQ(stats.hits, 4u);
  EXPECT_EQ(stats.misses, 10u);
}

// ComputeMetrics keeps the reference's display encodings (RGB and luminance, for PSNR and SSIM)
// in its ReferenceCache with the other halves; they are found again only for the same reference
// pixels in the same window around the mask and the same exposure: a call that changes any of
// them in turn, with one cache, gives the numbers of a call without it.
TEST(ReferenceCacheTest, DisplayEncodingsAreKeptPerPixelsWindowAndExposure) {
  const CacheInputs in;
  const Image &ref = in.ref, &tst = in.tst, &other_ref = in.other_ref, &mask = in.mask;
  const Image smaller = EllipseMask(96, 80, 47.0, 41.0, 22.0, 18.0, false);  // Its own window.
  struct Call {
    const Image* reference;
    const Image* mask;
    float exposure_stops;
  };
  const Call calls[] = {{&ref, &mask, 0.0f},   {&ref, &mask, 0.0f},     {&other_ref, &mask, 0.0f},
                        {&ref, &smaller, 0.0f}, {&ref, &mask, -1.5f}, {&ref, &mask, 0.0f}};
  ReferenceCache cache(64 << 20);
  for (const Call& c : calls) {
    MetricsParameters p;
    p.exposure_stops = c.exposure_stops;
    const std::string plain = MetricsToJson(ComputeMetrics(*c.reference, tst, c.mask, p)).dump();
    p.reference_cache = &cache;
    EXPECT_EQ(MetricsToJson(ComputeMetrics(*c.reference, tst, c.mask, p)).dump(), plain)
        << "stops " << c.exposure_stops;
  }
  EXPECT_GT(cache.stats().hits, 0u);
}

TEST(FalseColorTest, EndsOfTheScaleAndNan) {
  Image map(3, 1, 1);
  map.data = {0.0f, 1.0f, std::nanf("")};
  FalseColorParameters p;
  p.color_bar = false;
  p.min = 0.0;
  p.max = 1.0;
  const Image rgb = FalseColor(map, p);
  ASSERT_EQ(rgb.width, 3);
  // viridis starts dark purple (0.267, 0.005, 0.329) and ends yellow (0.993, 0.906, 0.144).
  EXPECT_NEAR(rgb.at(0, 0, 0), 0.267004f, 1e-6f);
  EXPECT_NEAR(rgb.at(1, 0, 1), 0.906157f, 1e-6f);
  EXPECT_NEAR(rgb.at(2, 0, 0), 0.5f, 1e-6f);
  p.color_map = ColorMap::kMagma;
  EXPECT_NEAR(FalseColor(map, p).at(0, 0, 2), 0.013866f, 1e-6f);  // magma's first entry.
}

TEST(FalseColorTest, ColorBarRunsFromMaxAtTopToMinAtBottom) {
  Image map(40, 40, 1, 0.5f);
  const Image rgb = FalseColor(map, {});
  ASSERT_GT(rgb.width, 40);
  const int bar_x = 40 + 4 + 6;                         // Middle of the bar.
  EXPECT_NEAR(rgb.at(bar_x, 39, 0), 0.267004f, 1e-6f);  // min at the bottom
  EXPECT_NEAR(rgb.at(bar_x, 0, 1), 0.906157f, 1e-6f);   // max at the top
}

}  // namespace
}  // namespace shadefit::metrics
