// Fitting the encoding of photographs along with the material (docs/measured_and_imported.md,
// "Photographs"). A camera's stored values are not always sRGB: some store linear values, some a
// pure power ("gamma 2.2"), some a curve of their own. The fit decodes the stored values with
// each candidate, fits the material (and a free exposure) in linear radiance as usual, and
// scores each candidate where the candidates are comparable: in the stored values. Linear-space
// costs under different decodings are not comparable (a decoding that darkens every pixel
// lowers the linear cost without explaining the data any better), so each candidate's score is
// the RMSE between the encoded prediction, encode(exposure x render), clamped to [0, 1], and the
// stored values, over the valid, fully covered pixels of the training references. The candidates
// are sRGB, linear and a pure power whose exponent a golden-section search (Kiefer 1953) finds
// in [gamma_min, gamma_max]; the lowest score wins, except that the fitted power, which has one
// more free parameter, must beat the better fixed encoding by gamma_margin.
//
// The fitter itself is untouched: every candidate is an ordinary Fit() of re-decoded references.
// sRGB, linear and the first power run the caller's starts; every later power starts from the
// material of the fit of the nearest exponent tried, alone (a continuation: neighbouring
// decodings change the material little; the exposure starts afresh), at a fraction of a cold
// multi-start's cost. It ended as low as the cold fits in our tests and lower at one exponent of
// the 96-light benchmark set (a cold fit there stopped in a worse basin), but that is measured,
// not guaranteed. The chosen encoding's final fit runs the caller's options again; a chosen
// power's adds its search fit's end as a start point.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "shadefit/base/enum_names.h"
#include "shadefit/fit/fit_types.h"

namespace shadefit::fit {

struct StoredEncoding {
  enum class Kind { kSrgb, kLinear, kGamma };
  Kind kind = Kind::kSrgb;
  double gamma = 1.0;  // kGamma: stored = linear^(1 / gamma), linear = stored^gamma.

  double Decode(double stored) const;  // Stored value in [0, 1] -> linear.
  double Encode(double linear) const;  // Linear -> stored value, clamped to [0, 1].
  std::string Name() const;            // "srgb", "linear", "gamma 2.2"
};

// "as-imported" (the encoding the import applied, recorded in the sidecar) or "fit" (search).
enum class EncodingMode { kAsImported, kFit };
inline constexpr EnumName<EncodingMode> kEncodingModeNames[] = {
    {EncodingMode::kAsImported, "as-imported"}, {EncodingMode::kFit, "fit"}};
EncodingMode ParseEncodingMode(const std::string& name);  // Throws FitOptionError.
std::string EncodingModeName(EncodingMode mode);

struct EncodingSearchOptions {
  double gamma_min = 1.0;  // Golden-section bracket of the pure power's exponent.
  double gamma_max = 3.0;
  double gamma_tolerance = 0.005;  // Bracket width at which the search stops.
  double gamma_margin = 0.02;      // Relative score margin the fitted power must win by.
};

struct EncodingCandidate {
  StoredEncoding encoding;
  double stored_rmse = 0;  // The score: RMSE in stored values (0..1), valid pixels, all channels.
  double linear_rmse = 0;  // The fit's own RMSE in linear radiance (not comparable across rows).
  double exposure = 1;
  bool converged = false;
};

struct EncodingSearchResult {
  StoredEncoding chosen;
  std::vector<EncodingCandidate> candidates;  // srgb, linear, the best power: the table reported
  std::vector<std::pair<double, double>> gamma_trail;  // (gamma, score) of every power tried
  long pixels = 0;                                     // Pixel-channels scored
  FitResult fit;  // The chosen encoding's fit, with the caller's options
};

// The reference's stored values (its image undone by decoded_from) decoded with `encoding`;
// alpha, mask, scene and clip rule are kept (the clip level is re-expressed in the new decoding).
reference_images::Reference Redecode(const reference_images::Reference& reference,
                                     const StoredEncoding& encoding);

// RMSE between encoding.Encode(exposure x prediction) and the stored values of `reference`
// over the pixels a fit uses (fully covered, in the mask, not clipped), all channels;
// `pixels` receives their count x 3. `prediction` is a render (RGB(A)) of reference's size.
double StoredRmse(const reference_images::Reference& reference, const Image& prediction,
                  double exposure, const StoredEncoding& encoding, long* pixels = nullptr);

// The search above. options.exposure must be Exposure::kFree (Error otherwise: an unknown
// encoding comes with an unknown exposure, and fixing one biases the other).
EncodingSearchResult FitWithEncodingSearch(const FitProblem& problem, const FitOptions& options,
                                           const EncodingSearchOptions& search = {});

// {"mode": "fit", "chosen": "gamma", "gamma": 2.2, "name": "gamma 2.2", "score": ..., "candidates":
// [...], "gamma_search": [[g, score], ...]}.
nlohmann::json EncodingSearchToJson(const EncodingSearchResult& result);

}  // namespace shadefit::fit
