// BRDF-space fits (brdf_space.h): the measured BRDF on MERL's cells as shading points, then the
// stages every fit runs (solve.h).
#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/option_checks.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "prepared_reference.h"
#include "shadefit/base/cpus.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "solve.h"

namespace shadefit::fit {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Beyond this theta_d the MERL tables hold extrapolated values (docs/probes.md).
constexpr double kMeasuredThetaDDeg = 75.0;

// One theta_h row of cells: its points, targets and weights before normalisation.
struct Row {
  std::vector<ShadingPoint> points;
  std::vector<Vec3d> values;  // f cos theta_i
  std::vector<double> weights;
  std::vector<bool> extrapolated;
  std::string error;  // First bad value, with its angles; empty when none.
};

Row SampleRow(const reference_images::MeasuredBrdf& brdf, const BrdfSpaceSampling& s, int i) {
  Row row;
  const double cos_cut = std::cos(s.max_theta_deg * kPi / 180.0);
  // theta_h = u^2 pi/2 with u uniform (MERL's square-root cells), at the cell's midpoint in u.
  const double u = (i + 0.5) / s.theta_h_cells;
  const double theta_h = u * u * kPi / 2;
  const double d_theta_h = kPi * u / s.theta_h_cells;  // (d theta_h / du) du
  const double d_theta_d = kPi / 2 / s.theta_d_cells;
  const double d_phi_d = kPi / s.phi_d_cells;
  for (int j = 0; j < s.theta_d_cells; ++j) {
    const double theta_d = (j + 0.5) * d_theta_d;
    for (int k = 0; k < s.phi_d_cells; ++k) {
      const double phi_d = (k + 0.5) * d_phi_d;
      Vec3d wi, wo;
      reference_images::FromHalfDiff(theta_h, theta_d, phi_d, &wi, &wo);
      if (!(wi.z > cos_cut) || !(wo.z > cos_cut)) continue;
      const Vec3d f = brdf.Eval(wi, wo);
      for (double c : {f.x, f.y, f.z}) {
        if (!std::isfinite(c) || c < 0) {
          if (row.error.empty()) {
            row.error = fmt::format("f = {} at theta_h {:.4g}, theta_d {:.4g}, phi_d {:.4g} deg", c,
                                    theta_h * 180 / kPi, theta_d * 180 / kPi, phi_d * 180 / kPi);
          }
        }
      }
      ShadingPoint p;
      p.n = Vec3d{0, 0, 1};
      p.v = wo;
      p.lights.push_back(PixelLight{wi, Vec3d{1, 1, 1}});
      row.points.push_back(std::move(p));
      row.values.push_back(f * wi.z);
      row.weights.push_back(4 * std::cos(theta_d) * std::sin(theta_h) * std::sin(theta_d) *
                            d_theta_h * d_theta_d * d_phi_d);
      row.extrapolated.push_back(theta_d * 180 / kPi > kMeasuredThetaDDeg);
    }
  }
  return row;
}

}  // namespace

void ValidateBrdfSpaceSampling(const BrdfSpaceSampling& s, const std::string& file) {
  auto count = [&](int v, const char* field) {
    if (v < 2 || v > 1024) {
      throw Error(file, fmt::format("brdf_space.{}", field),
                  fmt::format("must be an integer in [2, 1024], got {}", v));
    }
  };
  count(s.theta_h_cells, "theta_h_cells");
  count(s.theta_d_cells, "theta_d_cells");
  count(s.phi_d_cells, "phi_d_cells");
  if (!(s.max_theta_deg > 0 && s.max_theta_deg < 90)) {
    throw Error(file, "brdf_space.max_theta_deg",
                fmt::format("must be in (0, 90) degrees, got {}", s.max_theta_deg));
  }
}

void CheckBrdfSpaceOptions(const FitOptions& options) {
  if (options.loss != Loss::kL2) {
    throw FitOptionError(FitField::kLoss,
                fmt::format("a BRDF-space fit is an L2 fit of the cosine-weighted BRDF (Ngan et "
                            "al. 2005); got '{}'",
                            LossName(options.loss)));
  }
  if (options.exposure != Exposure::kFixed) {
    throw FitOptionError(FitField::kExposure,
                         "a measured BRDF has no unknown scale: the exposure is fixed");
  }
  if (options.starts < 1) throw FitOptionError(FitField::kStarts, "must be >= 1");
}

BrdfSpaceData SampleBrdfSpace(const reference_images::MeasuredBrdf& brdf,
                              const BrdfSpaceSampling& sampling) {
  BrdfSpaceData data;
  data.files = brdf.SourceFiles();
  data.label = data.files.empty() ? "brdf" : data.files.front();
  ValidateBrdfSpaceSampling(sampling, data.label);
  for (const std::string& f : data.files) data.sha256.push_back(Sha256File(f));
  data.format = brdf.Format();
  data.sampling = sampling;

  // Rows are independent; each thread takes every T-th row and the rows are joined in order,
  // so the data is the same bytes for any thread count.
  std::vector<Row> rows(static_cast<std::size_t>(sampling.theta_h_cells));
  const int threads = std::max(1, std::min(sampling.theta_h_cells, UsableCpus()));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int i = t; i < sampling.theta_h_cells; i += threads)
        rows[i] = SampleRow(brdf, sampling, i);
    });
  }
  for (std::thread& th : pool) th.join();

  double weight_sum = 0;
  std::size_t n = 0;
  for (const Row& row : rows) {
    if (!row.error.empty()) throw Error(data.label, "value", row.error);
    for (double w : row.weights) weight_sum += w;
    n += row.points.size();
  }
  if (n == 0) throw Error(data.label, "brdf_space", "no cell inside the angle cut");
  const double mean_w = weight_sum / static_cast<double>(n);
  bool any_light = false;
  double extrapolated_w = 0;
  data.points.reserve(n);
  data.targets.reserve(3 * n);
  data.weights.reserve(n);
  for (Row& row : rows) {
    for (std::size_t k = 0; k < row.points.size(); ++k) {
      const double w = row.weights[k] / mean_w;
      const double s = std::sqrt(w);
      ShadingPoint& p = row.points[k];
      p.lights[0].irradiance = Vec3d{s, s, s};
      for (double c : {row.values[k].x, row.values[k].y, row.values[k].z}) {
        data.targets.push_back(s * c);
        any_light = any_light || c > 0;
      }
      data.weights.push_back(w);
      if (row.extrapolated[k]) extrapolated_w += w;
      data.points.push_back(std::move(p));
    }
  }
  if (!any_light) throw Error(data.label, "value", "the BRDF is zero on every cell");
  data.extrapolated_fraction = extrapolated_w / static_cast<double>(n);
  return data;
}

FitResult FitBrdfSpace(const ModelInfo& model, const std::vector<FixedValue>& fixed,
                       BrdfSpaceData data, const FitOptions& given) {
  const auto t0 = std::chrono::steady_clock::now();
  const Parametrization param(model, fixed);
  CheckBrdfSpaceOptions(given);
  if (param.FreeCount() == 0) {
    throw FitOptionError(FitField::kFixed, "every parameter is fixed: nothing to fit");
  }
  if (data.points.empty() || data.targets.size() != 3 * data.points.size()) {
    throw Error(data.label, "brdf_space", "no sampled cells (SampleBrdfSpace first)");
  }
  FitOptions options = given;
  options.render_outputs = false;
  options.path = DerivativePath::kGBuffer;
  options.renderer = nullptr;

  FitResult result;
  result.model = model;
  result.loss = options.loss;
  result.starts = options.starts;
  result.seed = options.seed;
  result.path = DerivativePath::kGBuffer;

  FitReference source;
  source.name = "brdf-space";
  std::vector<internal::PreparedReference> refs(1);
  internal::PreparedReference& r = refs[0];
  r.source = &source;
  r.label = data.label;
  const std::size_t cells = data.points.size();
  r.points = std::move(data.points);  // `pixels` stays empty: only the GL path reads it
  r.linear = std::move(data.targets);

  internal::SolvePrepared(model, param, options, false, false, nullptr, refs, &result);

  nlohmann::json files = nlohmann::json::array();
  for (std::size_t i = 0; i < data.files.size(); ++i) {
    files.push_back({{"path", data.files[i]}, {"sha256", data.sha256[i]}});
  }
  result.inputs = {
      {"hash", "sha256"},
      {"brdf_space",
       {{"files", files},
        {"format", data.format},
        {"objective", "sqrt(sum w (f cos_i - f_model cos_i)^2 / sum w), Ngan et al. 2005"},
        {"theta_h_cells", data.sampling.theta_h_cells},
        {"theta_d_cells", data.sampling.theta_d_cells},
        {"phi_d_cells", data.sampling.phi_d_cells},
        {"max_theta_deg", data.sampling.max_theta_deg},
        {"cells", cells},
        {"extrapolated_weight_fraction", data.extrapolated_fraction}}},
      {"references", nlohmann::json::array()},
      {"fixed", FixedTexts(fixed)}};
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace shadefit::fit
