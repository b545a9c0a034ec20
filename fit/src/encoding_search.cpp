// The encoding search of encoding_search.h: every candidate is an ordinary Fit() of the training
// references re-decoded with it, scored in stored values.
#include "shadefit/fit/encoding_search.h"

#include "shadefit/fit/fitter.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "prepared_reference.h"
#include "shadefit/base/error.h"

namespace shadefit::fit {
namespace {

// The fitter's rule for a usable pixel (fit/src/prepared_reference.cpp: full coverage).
constexpr float kFullCoverage = 1.0f - 1e-5f;

// The value the file stored, from the linear value the reference holds.
double StoredOf(const reference_images::Reference& ref, double linear) {
  if (ref.decoded_from == reference_images::Encoding::kSrgb) {
    return SrgbOetf(static_cast<float>(std::clamp(linear, 0.0, 1.0)));
  }
  return linear;
}

bool Usable(const reference_images::Reference& ref, int x, int y) {
  const Image& im = ref.image;
  if (im.channels >= 4 && !(im.at(x, y, 3) >= kFullCoverage)) return false;
  if (!ref.mask.empty() && !(ref.mask.at(x, y, 0) > 0.5f)) return false;
  for (int c = 0; c < 3; ++c) {
    if (!(im.at(x, y, c) < ref.clip_level)) return false;
  }
  return true;
}

struct Scored {
  EncodingCandidate candidate;
  long pixels = 0;
  std::vector<double> values;  // The fit's (FitResult::values).
};

// Fits `problem` with every reference re-decoded by `e` and scores the fit in stored values.
// `shaded`: the references' G-buffer shading, shared by every candidate (the decoding changes
// values, not scenes: internal::ShadeScene). `warm`: the fit starts there alone (the caller's
// starts are not run).
Scored FitAndScore(const FitProblem& problem, const FitOptions& options, const StoredEncoding& e,
                   std::vector<internal::ShadedScene>* shaded,
                   const std::vector<double>* warm = nullptr) {
  FitProblem decoded = problem;
  for (reference_images::Reference& r : decoded.references) r = Redecode(r, e);
  FitOptions quick = options;
  quick.render_outputs = false;
  quick.compute_covariance = false;
  if (warm) {
    quick.starts = 0;
    quick.start_points = {*warm};
  }
  const FitResult fit = internal::FitSharingShading(decoded, quick, shaded);
  Scored s;
  s.candidate.encoding = e;
  s.candidate.linear_rmse = fit.rmse;
  s.candidate.exposure = fit.exposure;
  s.candidate.converged = fit.converged;
  s.values = fit.values;
  double sq = 0;
  // The fitted model's render of each training reference (what EvaluateModelOnReference renders,
  // without preparing the reference's pixels again: the score takes its own).
  internal::RendererHolder holder(options.renderer);
  for (std::size_t i = 0; i < problem.references.size(); ++i) {
    const Image prediction =
        holder.renderer->Render(decoded.references[i].scene, problem.model->id, fit.values);
    long n = 0;
    const double rmse = StoredRmse(problem.references[i], prediction, fit.exposure, e, &n);
    sq += rmse * rmse * n;
    s.pixels += n;
  }
  s.candidate.stored_rmse = s.pixels > 0 ? std::sqrt(sq / s.pixels) : 0.0;
  return s;
}

}  // namespace

double StoredEncoding::Decode(double v) const {
  v = std::clamp(v, 0.0, 1.0);
  switch (kind) {
    case Kind::kSrgb:
      return SrgbToLinear(static_cast<float>(v));
    case Kind::kLinear:
      return v;
    case Kind::kGamma:
      return std::pow(v, gamma);
  }
  return v;
}

double StoredEncoding::Encode(double v) const {
  v = std::clamp(v, 0.0, 1.0);
  switch (kind) {
    case Kind::kSrgb:
      return SrgbOetf(static_cast<float>(v));
    case Kind::kLinear:
      return v;
    case Kind::kGamma:
      return std::pow(v, 1.0 / gamma);
  }
  return v;
}

std::string StoredEncoding::Name() const {
  switch (kind) {
    case Kind::kSrgb:
      return "srgb";
    case Kind::kLinear:
      return "linear";
    case Kind::kGamma:
      return fmt::format("gamma {:.3f}", gamma);
  }
  return "";
}

std::string EncodingModeName(EncodingMode mode) {
  return std::string(NameOf(kEncodingModeNames, mode));
}

reference_images::Reference Redecode(const reference_images::Reference& ref,
                                     const StoredEncoding& e) {
  reference_images::Reference out = ref;
  for (int y = 0; y < ref.image.height; ++y) {
    for (int x = 0; x < ref.image.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        out.image.at(x, y, c) = static_cast<float>(e.Decode(StoredOf(ref, ref.image.at(x, y, c))));
      }
    }
  }
  if (std::isfinite(ref.clip_level)) {
    out.clip_level = static_cast<float>(e.Decode(StoredOf(ref, ref.clip_level)));
  }
  return out;
}

double StoredRmse(const reference_images::Reference& ref, const Image& prediction, double exposure,
                  const StoredEncoding& e, long* pixels) {
  double sq = 0;
  long n = 0;
  for (int y = 0; y < ref.image.height; ++y) {
    for (int x = 0; x < ref.image.width; ++x) {
      if (!Usable(ref, x, y)) continue;
      for (int c = 0; c < 3; ++c) {
        const double d =
            e.Encode(exposure * prediction.at(x, y, c)) - StoredOf(ref, ref.image.at(x, y, c));
        sq += d * d;
        ++n;
      }
    }
  }
  if (pixels) *pixels = n;
  return n > 0 ? std::sqrt(sq / n) : 0.0;
}

EncodingSearchResult FitWithEncodingSearch(const FitProblem& problem, const FitOptions& options,
                                           const EncodingSearchOptions& search) {
  if (options.exposure != Exposure::kFree) {
    throw Error("", "encoding",
                "fitting the encoding needs a free exposure (--exposure free / exposure = "
                "\"free\"): an unknown encoding comes with an unknown exposure");
  }
  if (!(search.gamma_min > 0) || !(search.gamma_max > search.gamma_min)) {
    throw Error("", "encoding", "the gamma bracket must satisfy 0 < gamma_min < gamma_max");
  }
  EncodingSearchResult result;
  using Kind = StoredEncoding::Kind;
  std::vector<internal::ShadedScene> shaded;
  const Scored srgb = FitAndScore(problem, options, {Kind::kSrgb, 1.0}, &shaded);
  const Scored linear = FitAndScore(problem, options, {Kind::kLinear, 1.0}, &shaded);
  result.pixels = srgb.pixels;

  // Golden-section search of the power's exponent (Kiefer 1953): the score is taken as
  // unimodal in gamma over the bracket. The first power is fitted with the caller's starts; each
  // later one starts from the fit of the nearest exponent tried, alone (a continuation: the
  // material changes little between neighbouring decodings), at a fraction of the cost.
  std::vector<std::pair<double, std::vector<double>>> fitted;  // (gamma, values) of each power
  auto score = [&](double g) {
    const std::vector<double>* nearest = nullptr;
    double distance = std::numeric_limits<double>::infinity();
    for (const auto& [tried, values] : fitted) {
      if (std::abs(tried - g) < distance) {
        distance = std::abs(tried - g);
        nearest = &values;
      }
    }
    Scored s = FitAndScore(problem, options, {Kind::kGamma, g}, &shaded, nearest);
    result.gamma_trail.emplace_back(g, s.candidate.stored_rmse);
    fitted.emplace_back(g, std::move(s.values));
    return s.candidate;
  };
  const double inv_phi = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = search.gamma_min, b = search.gamma_max;
  double c = b - inv_phi * (b - a), d = a + inv_phi * (b - a);
  EncodingCandidate fc = score(c), fd = score(d);
  while (b - a > search.gamma_tolerance) {
    if (fc.stored_rmse < fd.stored_rmse) {
      b = d;
      d = c;
      fd = fc;
      c = b - inv_phi * (b - a);
      fc = score(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + inv_phi * (b - a);
      fd = score(d);
    }
  }
  const EncodingCandidate power = fc.stored_rmse < fd.stored_rmse ? fc : fd;
  result.candidates = {srgb.candidate, linear.candidate, power};

  const EncodingCandidate& fixed = srgb.candidate.stored_rmse <= linear.candidate.stored_rmse
                                       ? srgb.candidate
                                       : linear.candidate;
  result.chosen = power.stored_rmse < (1.0 - search.gamma_margin) * fixed.stored_rmse
                      ? power.encoding
                      : fixed.encoding;

  // The chosen encoding's fit once more, with the caller's options (outputs, covariance). A
  // power's also starts where its search fit ended, which a continued fit can reach and the
  // caller's starts miss: the final fit ends at least as low as the score the choice was made on.
  FitProblem decoded = problem;
  for (reference_images::Reference& r : decoded.references) r = Redecode(r, result.chosen);
  FitOptions final_options = options;
  if (result.chosen.kind == Kind::kGamma) {
    for (const auto& [tried, values] : fitted) {
      if (tried == result.chosen.gamma) final_options.start_points.push_back(values);
    }
  }
  result.fit = Fit(decoded, final_options);
  return result;
}

nlohmann::json EncodingSearchToJson(const EncodingSearchResult& r) {
  auto kind_name = [](const StoredEncoding& e) {
    return e.kind == StoredEncoding::Kind::kGamma ? std::string("gamma") : e.Name();
  };
  nlohmann::json candidates = nlohmann::json::array();
  double chosen_score = std::numeric_limits<double>::quiet_NaN();
  for (const EncodingCandidate& c : r.candidates) {
    const bool chosen = c.encoding.kind == r.chosen.kind;
    if (chosen) chosen_score = c.stored_rmse;
    candidates.push_back({{"encoding", kind_name(c.encoding)},
                          {"name", c.encoding.Name()},
                          {"gamma", c.encoding.kind == StoredEncoding::Kind::kGamma
                                        ? nlohmann::json(c.encoding.gamma)
                                        : nlohmann::json(nullptr)},
                          {"stored_rmse", c.stored_rmse},
                          {"linear_rmse", c.linear_rmse},
                          {"exposure", c.exposure},
                          {"converged", c.converged},
                          {"chosen", chosen}});
  }
  nlohmann::json trail = nlohmann::json::array();
  for (const auto& [g, s] : r.gamma_trail) trail.push_back({g, s});
  return {{"mode", "fit"},
          {"chosen", kind_name(r.chosen)},
          {"name", r.chosen.Name()},
          {"gamma", r.chosen.kind == StoredEncoding::Kind::kGamma ? nlohmann::json(r.chosen.gamma)
                                                                  : nlohmann::json(nullptr)},
          {"stored_rmse", chosen_score},
          {"scored_values", r.pixels},
          {"score",
           "RMSE between encode(exposure x prediction), clamped to [0, 1], and the stored "
           "values (0..1) over the training references' valid pixels"},
          {"candidates", candidates},
          {"gamma_search", trail}};
}

}  // namespace shadefit::fit
