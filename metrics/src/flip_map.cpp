// The LDR-FLIP map (Andersson et al. 2020, Sec. 4): colour spaces, CSF and feature filters, each
// image's half of the map (colour and feature pipelines) and the per-pixel combination of two.
#include "flip_map.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>

#include "internal.h"
#include "weighted_sum.h"

namespace shadefit::metrics::internal {
namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;

constexpr double kPi = std::numbers::pi;

// FLIP constants (Andersson et al. 2020): q_c, p_c, p_t of the colour-difference remapping
// (Sec. 4.1, Eq. 4-5), feature width w in degrees and q_f of the feature difference (Sec. 4.2).
constexpr float kQc = 0.7f;
constexpr float kPc = 0.4f;
constexpr float kPt = 0.95f;
constexpr float kFeatureWidthDegrees = 0.082f;
constexpr float kQf = 0.5f;

// Contrast sensitivity functions as sums of Gaussians in the frequency domain,
// CSF(f) = a1 exp(-b1 f^2) + a2 exp(-b2 f^2) (Andersson et al. 2020, Sec. 4.1, Table 1), for the
// achromatic (Y), red-green (Cx) and blue-yellow (Cz) channels. In the spatial domain each term is
// a Gaussian a sqrt(pi / b) exp(-pi^2 x^2 / b), x in degrees (Eq. 3).
struct Csf {
  double a1, b1, a2, b2;
};
constexpr Csf kCsfY = {1.0, 0.0047, 0.0, 1.0e-5};
constexpr Csf kCsfCx = {1.0, 0.0053, 0.0, 1.0e-5};
constexpr Csf kCsfCz = {34.1, 0.04, 13.5, 0.025};

Mat3 Inverse(const Mat3& m) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  Mat3 inv;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      // Cofactor of (c, r) over the determinant.
      const int r0 = (c + 1) % 3, r1 = (c + 2) % 3, c0 = (r + 1) % 3, c1 = (r + 2) % 3;
      inv[r][c] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
    }
  }
  return inv;
}

// Linear sRGB <-> XYZ, derived from the sRGB primaries and D65 white chromaticities of
// IEC 61966-2-1 (R 0.64/0.33, G 0.30/0.60, B 0.15/0.06, W 0.3127/0.3290), and the white XYZ.
struct ColorSpace {
  Mat3 rgb_to_xyz;
  Mat3 xyz_to_rgb;
  std::array<double, 3> white;  // XYZ of RGB (1, 1, 1); Y = 1.
};

const ColorSpace& Srgb() {
  static const ColorSpace space = [] {
    const double xy[4][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}, {0.3127, 0.3290}};
    Mat3 primaries;  // Columns: XYZ of each primary with Y = 1.
    for (int i = 0; i < 3; ++i) {
      primaries[0][i] = xy[i][0] / xy[i][1];
      primaries[1][i] = 1.0;
      primaries[2][i] = (1.0 - xy[i][0] - xy[i][1]) / xy[i][1];
    }
    const std::array<double, 3> w = {xy[3][0] / xy[3][1], 1.0,
                                     (1.0 - xy[3][0] - xy[3][1]) / xy[3][1]};
    const Mat3 inv = Inverse(primaries);
    ColorSpace s;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        const double scale = inv[c][0] * w[0] + inv[c][1] * w[1] + inv[c][2] * w[2];
        s.rgb_to_xyz[r][c] = primaries[r][c] * scale;
      }
    }
    s.xyz_to_rgb = Inverse(s.rgb_to_xyz);
    s.white = w;
    return s;
  }();
  return space;
}

// CIELAB's f(t) (CIE 15): t^(1/3) above (6/29)^3, linear below. The cube root without libm's
// cbrtf (the hottest call of FLIP's colour pipeline): an exponent-dividing bit trick (error
// < 4 %) refined by two Halley steps y <- y (y^3 + 2t) / (2y^3 + t) in double; the cubic
// convergence leaves a relative error far below float epsilon. Both sides are computed and one
// kept by a mask, not a branch, so that a row of it vectorises (HuntLabRow); t >= 0.
inline float LabF(float t) {
  constexpr float kDelta = 6.0f / 29.0f;
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(t) / 3u + 709921077u;
  double y = std::bit_cast<float>(bits);
  double y3 = y * y * y;
  y *= (y3 + 2.0 * t) / (2.0 * y3 + t);
  y3 = y * y * y;
  y *= (y3 + 2.0 * t) / (2.0 * y3 + t);
  const float cube_root = static_cast<float>(y);
  const float linear = t / (3.0f * kDelta * kDelta) + 4.0f / 29.0f;
  const std::uint32_t keep = 0u - static_cast<std::uint32_t>(t > kDelta * kDelta * kDelta);
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(cube_root) & keep) |
                              (std::bit_cast<std::uint32_t>(linear) & ~keep));
}

// The colour space's numbers in the float precision the per-pixel conversions use.
struct HuntLabConstants {
  float white_x, white_z;
  float to_rgb[3][3], to_xyz[3][3];
};

const HuntLabConstants& HuntLabK() {
  static const HuntLabConstants k = [] {
    const ColorSpace& s = Srgb();
    HuntLabConstants c;
    c.white_x = static_cast<float>(s.white[0]);
    c.white_z = static_cast<float>(s.white[2]);
    for (int r = 0; r < 3; ++r) {
      for (int j = 0; j < 3; ++j) {
        c.to_rgb[r][j] = static_cast<float>(s.xyz_to_rgb[r][j]);
        c.to_xyz[r][j] = static_cast<float>(s.rgb_to_xyz[r][j]);
      }
    }
    return c;
  }();
  return k;
}

// Linear RGB -> CIELAB (D65, white Y = 1), then the Hunt adjustment a, b *= 0.01 L (Andersson et
// al. 2020, Sec. 4.1): chroma matters less in dark regions.
inline Float3 LinearRgbToHuntLab(const HuntLabConstants& k, float r, float g, float b) {
  float xyz[3];
  for (int i = 0; i < 3; ++i) xyz[i] = k.to_xyz[i][0] * r + k.to_xyz[i][1] * g + k.to_xyz[i][2] * b;
  const float fx = LabF(xyz[0] / k.white_x);
  const float fy = LabF(xyz[1]);
  const float fz = LabF(xyz[2] / k.white_z);
  const float l = 116.0f * fy - 16.0f;
  return {{l, 0.01f * l * 500.0f * (fx - fy), 0.01f * l * 200.0f * (fy - fz)}};
}

// HyAB distance (Abasi et al. 2020): city-block in L, Euclidean in (a, b).
float HyAB(const Float3& x, const Float3& y) {
  const float da = x.v[1] - y.v[1], db = x.v[2] - y.v[2];
  return std::abs(x.v[0] - y.v[0]) + std::sqrt(da * da + db * db);
}

// Largest colour difference, between Hunt-adjusted green and blue, raised to q_c (Sec. 4.1).
float MaxColorDifference() {
  const HuntLabConstants& k = HuntLabK();
  return std::pow(HyAB(LinearRgbToHuntLab(k, 0, 1, 0), LinearRgbToHuntLab(k, 0, 0, 1)), kQc);
}

// Runs body(pixel index) for every pixel of `spans`, rows split across threads.
template <typename Body>
void ForEachPixel(int w, const RowSpans& spans, Body body) {
  internal::ParallelRows(static_cast<int>(spans.begin.size()), [&](int begin, int end) {
    for (int y = begin; y < end; ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * w;
      for (int x = spans.begin[y]; x < spans.end[y]; ++x) body(row + x);
    }
  });
}

// The spans whose pixels are within `radius` rows of a pixel of `spans` in the same column: the
// hull per row of the spans of rows y - radius .. y + radius (what a column filter reads).
RowSpans DilateRows(const RowSpans& spans, int radius) {
  const int h = static_cast<int>(spans.begin.size());
  RowSpans out{std::vector<int>(h, 0), std::vector<int>(h, 0)};
  for (int y = 0; y < h; ++y) {
    for (int k = std::max(0, y - radius); k <= std::min(h - 1, y + radius); ++k) {
      if (spans.begin[k] >= spans.end[k]) continue;
      if (out.begin[y] >= out.end[y]) {
        out.begin[y] = spans.begin[k];
        out.end[y] = spans.end[k];
      } else {
        out.begin[y] = std::min(out.begin[y], spans.begin[k]);
        out.end[y] = std::max(out.end[y], spans.end[k]);
      }
    }
  }
  return out;
}

// Each non-empty span widened by `radius` columns, within [0, w) (what a row filter reads).
RowSpans WidenColumns(RowSpans spans, int radius, int w) {
  for (std::size_t y = 0; y < spans.begin.size(); ++y) {
    if (spans.begin[y] >= spans.end[y]) continue;
    spans.begin[y] = std::max(0, spans.begin[y] - radius);
    spans.end[y] = std::min(w, spans.end[y] + radius);
  }
  return spans;
}

// The filters' inner loop (weighted_sum.h), built for AVX2 and the baseline. Along a row:
// in(k) = in + k (the row's pixels from the first tap's on).
[[gnu::target_clones("avx2", "default")]] void ConvolveRow(float* out, const float* in,
                                                            const float* taps, int ntaps, int n) {
  WeightedSum(out, taps, ntaps, n, [in](int k) { return in + k; });
}

// Down a column: in(k) = rows[k] (the rows of the taps, from the first's on).
[[gnu::target_clones("avx2", "default")]] void ConvolveColumn(float* out,
                                                               const float* const* rows,
                                                               const float* taps, int ntaps,
                                                               int n) {
  WeightedSum(out, taps, ntaps, n, [rows](int k) { return rows[k]; });
}

// Separable filtering with clamp-to-edge borders: the row pass at the pixels of `wanted`, which
// reads `in` within the taps' radius of them.
void FilterRows(const Plane& in, Plane& out, int w, const RowSpans& wanted,
                const std::vector<float>& taps) {
  const int r = static_cast<int>(taps.size()) / 2;
  out.resize(in.size());  // Cleared and written at the pixels of `wanted`, the only ones read.
  internal::ParallelRows(static_cast<int>(wanted.begin.size()), [&](int begin, int end) {
    std::vector<float> padded(w + 2 * r);
    for (int y = begin; y < end; ++y) {
      const int x0 = wanted.begin[y], x1 = wanted.end[y];
      if (x0 >= x1) continue;
      const float* row = &in[static_cast<std::size_t>(y) * w];
      // padded[j] holds column x0 - r + j, clamped to the frame: the columns inside it copied,
      // the first and last column repeated beyond it.
      const int lo = std::max(0, x0 - r), hi = std::min(w, x1 + r);
      std::fill(padded.begin(), padded.begin() + (lo - (x0 - r)), row[0]);
      std::memcpy(&padded[lo - (x0 - r)], row + lo, sizeof(float) * (hi - lo));
      std::fill(padded.begin() + (hi - (x0 - r)), padded.begin() + (x1 + r - (x0 - r)),
                row[w - 1]);
      ConvolveRow(&out[static_cast<std::size_t>(y) * w + x0], padded.data(), taps.data(),
                  2 * r + 1, x1 - x0);
    }
  });
}

// The column pass at the pixels of `wanted`, which reads `in` within the taps' radius of them in
// their columns.
void FilterColumns(const Plane& in, Plane& out, int w, const RowSpans& wanted,
                   const std::vector<float>& taps) {
  const int r = static_cast<int>(taps.size()) / 2;
  const int h = static_cast<int>(wanted.begin.size());
  out.resize(in.size());  // Cleared and written at the pixels of `wanted`, the only ones read.
  internal::ParallelRows(h, [&](int begin, int end) {
    std::vector<const float*> rows(2 * r + 1);
    for (int y = begin; y < end; ++y) {
      const int x0 = wanted.begin[y], x1 = wanted.end[y];
      if (x0 >= x1) continue;
      for (int k = -r; k <= r; ++k) {
        rows[k + r] = &in[static_cast<std::size_t>(std::clamp(y + k, 0, h - 1)) * w + x0];
      }
      ConvolveColumn(&out[static_cast<std::size_t>(y) * w + x0], rows.data(), taps.data(),
                     2 * r + 1, x1 - x0);
    }
  });
}

// What a side's stages read: the wanted pixels, the rows the column filters read (within the
// largest radius of them) and the columns the row filters read around those.
struct SideSpans {
  RowSpans wanted, rows, columns;
};

SideSpans SpansFor(const RowSpans& wanted, int radius, int w) {
  SideSpans s{wanted, DilateRows(wanted, radius), {}};
  s.columns = WidenColumns(s.rows, radius, w);
  return s;
}

// `out` at the pixels of spans.wanted; `tmp` holds the row pass.
void Filter2D(const Plane& in, int w, const SideSpans& spans, const std::vector<float>& row_taps,
              const std::vector<float>& column_taps, Plane& tmp, Plane& out) {
  FilterRows(in, tmp, w, spans.rows, row_taps);
  FilterColumns(tmp, out, w, spans.wanted, column_taps);
}

// 1-D factors of the CSF filters. The radius covers 3 standard deviations of the widest
// Gaussian (largest b): sigma = sqrt(b / (2 pi^2)) degrees. Y and Cx are single Gaussians,
// normalised to sum 1. Cz is a sum of two Gaussians, g1(x)g1(y) + g2(x)g2(y), each 2-D term
// factored as sqrt(a sqrt(pi / b)) exp(-pi^2 x^2 / b) per axis, scaled together so that the 2-D
// kernel sums to 1 (NVIDIA's misc/separatedConvolutions.pdf shows the same factoring).
struct CsfFilters {
  std::vector<float> y, cx, cz1, cz2;
};

double CsfRadius(double ppd) {
  double b_max = 0.0;
  for (const Csf& c : {kCsfY, kCsfCx, kCsfCz}) b_max = std::max({b_max, c.b1, c.b2});
  return std::ceil(3.0 * std::sqrt(b_max / (2.0 * kPi * kPi)) * ppd);
}

CsfFilters MakeCsfFilters(double ppd) {
  const int radius = static_cast<int>(CsfRadius(ppd));
  const int n = 2 * radius + 1;
  std::vector<double> y(n), cx(n), cz1(n), cz2(n);
  double sy = 0, scx = 0, s1 = 0, s2 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = (i - radius) / ppd;  // Degrees.
    const auto gaussian = [x](double a, double b) {
      return a * std::sqrt(kPi / b) * std::exp(-kPi * kPi * x * x / b);
    };
    y[i] = gaussian(kCsfY.a1, kCsfY.b1);  // a2 = 0: one term.
    cx[i] = gaussian(kCsfCx.a1, kCsfCx.b1);
    cz1[i] = std::sqrt(kCsfCz.a1 * std::sqrt(kPi / kCsfCz.b1)) *
             std::exp(-kPi * kPi * x * x / kCsfCz.b1);
    cz2[i] = std::sqrt(kCsfCz.a2 * std::sqrt(kPi / kCsfCz.b2)) *
             std::exp(-kPi * kPi * x * x / kCsfCz.b2);
    sy += y[i];
    scx += cx[i];
    s1 += cz1[i];
    s2 += cz2[i];
  }
  const double cz_norm = 1.0 / std::sqrt(s1 * s1 + s2 * s2);  // 2-D sum = (s1^2 + s2^2) -> 1.
  CsfFilters f;
  for (int i = 0; i < n; ++i) {
    f.y.push_back(static_cast<float>(y[i] / sy));
    f.cx.push_back(static_cast<float>(cx[i] / scx));
    f.cz1.push_back(static_cast<float>(cz1[i] * cz_norm));
    f.cz2.push_back(static_cast<float>(cz2[i] * cz_norm));
  }
  return f;
}

// Edge and point detectors (Sec. 4.2): first and second derivatives of a Gaussian with
// sigma = 0.5 w ppd pixels, radius ceil(3 sigma). The Gaussian sums to 1; the positive and
// negative weights of each derivative sum to +1 and -1 respectively.
struct FeatureFilters {
  std::vector<float> g, dg, ddg;
};

double FeatureSigma(double ppd) { return 0.5 * kFeatureWidthDegrees * ppd; }
double FeatureRadius(double ppd) { return std::ceil(3.0 * FeatureSigma(ppd)); }

FeatureFilters MakeFeatureFilters(double ppd) {
  const double sigma = FeatureSigma(ppd);
  const int radius = static_cast<int>(FeatureRadius(ppd));
  const int n = 2 * radius + 1;
  std::vector<double> g(n), dg(n), ddg(n);
  double g_sum = 0, dg_pos = 0, dg_neg = 0, ddg_pos = 0, ddg_neg = 0;
  for (int i = 0; i < n; ++i) {
    const double x = i - radius;
    g[i] = std::exp(-x * x / (2.0 * sigma * sigma));
    dg[i] = -x * g[i];
    ddg[i] = (x * x / (sigma * sigma) - 1.0) * g[i];
    g_sum += g[i];
    (dg[i] > 0 ? dg_pos : dg_neg) += std::abs(dg[i]);
    (ddg[i] > 0 ? ddg_pos : ddg_neg) += std::abs(ddg[i]);
  }
  FeatureFilters f;
  for (int i = 0; i < n; ++i) {
    f.g.push_back(static_cast<float>(g[i] / g_sum));
    f.dg.push_back(static_cast<float>(dg[i] / (dg[i] > 0 ? dg_pos : dg_neg)));
    f.ddg.push_back(static_cast<float>(ddg[i] / (ddg[i] > 0 ? ddg_pos : ddg_neg)));
  }
  return f;
}

// One row of linear RGB (the first three of `channels` per pixel) after the exposure `e`, each
// channel clamped to [0, 1], to YCxCz (Sec. 4.1): the linearised CIELAB of Flohr et al.,
// Y = 116 Y/Yn - 16, Cx = 500 (X/Xn - Y/Yn), Cz = 200 (Y/Yn - Z/Zn). The tone mapper is a
// template argument so that each variant is one loop the compiler vectorises; built for AVX2 too
// (no fused multiply-add: the same bits everywhere).
template <int kToneMap>  // 0: none (LDR-FLIP), 1: ACES, 2: Reinhard.
[[gnu::always_inline]] inline void YCxCzRowOf(const HuntLabConstants& k, const float* __restrict p,
                                              int channels, int n, float scale,
                                              float* __restrict y_out, float* __restrict cx_out,
                                              float* __restrict cz_out) {
  for (int i = 0; i < n; ++i) {
    float c[3] = {p[i * channels], p[i * channels + 1], p[i * channels + 2]};
    if constexpr (kToneMap != 0) {
      for (float& v : c) v *= scale;
    }
    if constexpr (kToneMap == 1) {
      // Narkowicz's ACES fit (kAces), per channel.
      for (float& x : c) {
        x = (kAces[0] * x * x + kAces[1] * x + kAces[2]) /
            (kAces[3] * x * x + kAces[4] * x + kAces[5]);
      }
    } else if constexpr (kToneMap == 2) {
      // Reinhard et al. 2002, global operator on luminance.
      const float l = 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
      for (float& v : c) v /= 1.0f + l;
    }
    for (float& v : c) v = std::clamp(v, 0.0f, 1.0f);
    float xyz[3];
    for (int r = 0; r < 3; ++r) {
      xyz[r] = k.to_xyz[r][0] * c[0] + k.to_xyz[r][1] * c[1] + k.to_xyz[r][2] * c[2];
    }
    const float x = xyz[0] / k.white_x;
    const float y = xyz[1];
    const float z = xyz[2] / k.white_z;
    y_out[i] = 116.0f * y - 16.0f;
    cx_out[i] = 500.0f * (x - y);
    cz_out[i] = 200.0f * (y - z);
  }
}

[[gnu::target_clones("avx2", "default")]] void YCxCzRow(const HuntLabConstants& k,
                                                         const Exposure& e, const float* p,
                                                         int channels, int n, float* y_out,
                                                         float* cx_out, float* cz_out) {
  if (!e.tone_map) {
    YCxCzRowOf<0>(k, p, channels, n, 1.0f, y_out, cx_out, cz_out);
  } else if (e.tone_mapper == FlipToneMapper::kReinhard) {
    YCxCzRowOf<2>(k, p, channels, n, e.scale, y_out, cx_out, cz_out);
  } else {
    YCxCzRowOf<1>(k, p, channels, n, e.scale, y_out, cx_out, cz_out);
  }
}

// The image's pixels in `spans` after the exposure `e` as YCxCz planes (YCxCzRow).
void ToYCxCz(const Image& rgb, const RowSpans& spans, const Exposure& e, std::array<Plane, 3>& out) {
  const HuntLabConstants& k = HuntLabK();
  const std::size_t n = rgb.PixelCount();
  for (Plane& plane : out) plane.resize(n);  // Written at the pixels of `spans`.
  internal::ParallelRows(static_cast<int>(spans.begin.size()), [&](int begin, int end) {
    for (int y = begin; y < end; ++y) {
      const int x0 = spans.begin[y], x1 = spans.end[y];
      if (x0 >= x1) continue;
      const std::size_t i0 = static_cast<std::size_t>(y) * rgb.width + x0;
      YCxCzRow(k, e, &rgb.data[i0 * rgb.channels], rgb.channels, x1 - x0, &out[0][i0],
               &out[1][i0], &out[2][i0]);
    }
  });
}

// One row of the colour pipeline's end (Sec. 4.1): filtered YCxCz back to linear RGB, clamped to
// [0, 1] (filtered colours can leave the gamut), then Hunt-adjusted CIELAB; the operations of
// LinearRgbToHuntLab in its order, so the same bits. Also built for AVX2 (no fused multiply-add:
// same rounding), chosen at run time: the Halley steps' divisions are this pipeline's hottest.
[[gnu::target_clones("avx2", "default")]] void HuntLabRow(
    const HuntLabConstants& k, const float* __restrict y, const float* __restrict cx,
    const float* __restrict cz1, const float* __restrict cz2, int n, float* __restrict l_out,
    float* __restrict a_out, float* __restrict b_out) {
  for (int i = 0; i < n; ++i) {
    const float yy = (y[i] + 16.0f) / 116.0f;
    const float xx = (yy + cx[i] / 500.0f) * k.white_x;
    const float zz = (yy - (cz1[i] + cz2[i]) / 200.0f) * k.white_z;
    float rgb[3];
    for (int r = 0; r < 3; ++r) {
      rgb[r] = std::clamp(k.to_rgb[r][0] * xx + k.to_rgb[r][1] * yy + k.to_rgb[r][2] * zz, 0.0f,
                          1.0f);
    }
    const Float3 lab = LinearRgbToHuntLab(k, rgb[0], rgb[1], rgb[2]);
    l_out[i] = lab.v[0];
    a_out[i] = lab.v[1];
    b_out[i] = lab.v[2];
  }
}

// Colour pipeline output per pixel, Hunt-adjusted CIELAB of the CSF-filtered image, into `lab`
// at the pixels of spans.wanted.
void FilteredHuntLab(const std::array<Plane, 3>& ycxcz, int w, const SideSpans& spans,
                     const CsfFilters& f, SideScratch& s, std::vector<Float3>& lab) {
  Filter2D(ycxcz[0], w, spans, f.y, f.y, s.tmp, s.y);
  Filter2D(ycxcz[1], w, spans, f.cx, f.cx, s.tmp, s.cx);
  Filter2D(ycxcz[2], w, spans, f.cz1, f.cz1, s.tmp, s.cz1);
  Filter2D(ycxcz[2], w, spans, f.cz2, f.cz2, s.tmp, s.cz2);
  const HuntLabConstants& k = HuntLabK();
  for (Plane& plane : s.lab) plane.resize(static_cast<std::size_t>(w));
  lab.resize(s.y.size(), Float3{{0.0f, 0.0f, 0.0f}});
  const RowSpans& wanted = spans.wanted;
  for (std::size_t row = 0; row < wanted.begin.size(); ++row) {
    const int x0 = wanted.begin[row], x1 = wanted.end[row];
    if (x0 >= x1) continue;
    const std::size_t i0 = row * w + x0;
    HuntLabRow(k, &s.y[i0], &s.cx[i0], &s.cz1[i0], &s.cz2[i0], x1 - x0, s.lab[0].data(),
               s.lab[1].data(), s.lab[2].data());
    for (int x = 0; x < x1 - x0; ++x) lab[i0 + x] = {{s.lab[0][x], s.lab[1][x], s.lab[2][x]}};
  }
}

// Edge and point features into `out` at the pixels of spans.wanted.
void DetectFeatures(const Plane& y_channel, int w, const SideSpans& spans, const FeatureFilters& f,
                    SideScratch& s, Features& out) {
  Plane& gray = s.gray;
  gray.resize(y_channel.size());
  ForEachPixel(w, spans.columns, [&](std::size_t i) { gray[i] = (y_channel[i] + 16.0f) / 116.0f; });
  FilterRows(gray, s.hg, w, spans.rows, f.g);
  FilterRows(gray, s.hdg, w, spans.rows, f.dg);
  FilterRows(gray, s.hddg, w, spans.rows, f.ddg);
  FilterColumns(s.hdg, s.ex, w, spans.wanted, f.g);   // d/dx
  FilterColumns(s.hg, s.ey, w, spans.wanted, f.dg);   // d/dy
  FilterColumns(s.hddg, s.px, w, spans.wanted, f.g);  // d2/dx2
  FilterColumns(s.hg, s.py, w, spans.wanted, f.ddg);  // d2/dy2
  out.edge.resize(gray.size(), 0.0f);
  out.point.resize(gray.size(), 0.0f);
  const Plane &ex = s.ex, &ey = s.ey, &px = s.px, &py = s.py;
  ForEachPixel(w, spans.wanted, [&](std::size_t i) {
    out.edge[i] = std::sqrt(ex[i] * ex[i] + ey[i] * ey[i]);
    out.point[i] = std::sqrt(px[i] * px[i] + py[i] * py[i]);
  });
}

}  // namespace

RowSpans FullSpans(int w, int h) { return {std::vector<int>(h, 0), std::vector<int>(h, w)}; }

RowSpans MaskSpans(const Image* mask, int w, int h) {
  if (mask == nullptr) return FullSpans(w, h);
  RowSpans spans{std::vector<int>(h, 0), std::vector<int>(h, 0)};
  for (int y = 0; y < h; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * w;
    int first = w, last = -1;
    for (int x = 0; x < w; ++x) {
      if (!internal::IsValid(mask, row + x)) continue;
      first = std::min(first, x);
      last = x;
    }
    if (last >= 0) {
      spans.begin[y] = first;
      spans.end[y] = last + 1;
    }
  }
  return spans;
}

double SideRadius(double ppd) { return std::max(CsfRadius(ppd), FeatureRadius(ppd)); }

std::uint64_t HashSpans(const RowSpans& spans) {
  std::uint64_t h = 0x9E3779B97F4A7C15ull ^ spans.begin.size();
  for (std::size_t y = 0; y < spans.begin.size(); ++y) {
    for (const std::uint64_t v : {static_cast<std::uint64_t>(spans.begin[y]),
                                  static_cast<std::uint64_t>(spans.end[y])}) {
      h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    }
  }
  return h;
}

void ComputeSide(const Image& rgb, double ppd, const RowSpans& wanted, const Exposure& exposure,
                 SideScratch& scratch, FlipSide& side) {
  const CsfFilters csf = MakeCsfFilters(ppd);
  const FeatureFilters features = MakeFeatureFilters(ppd);
  const int radius = static_cast<int>(SideRadius(ppd));
  const SideSpans spans = SpansFor(wanted, radius, rgb.width);
  ToYCxCz(rgb, spans.columns, exposure, scratch.ycxcz);
  FilteredHuntLab(scratch.ycxcz, rgb.width, spans, csf, scratch, side.lab);
  DetectFeatures(scratch.ycxcz[0], rgb.width, spans, features, scratch, side.features);
}

FlipSide ComputeSide(const Image& rgb, double ppd, const RowSpans& wanted,
                     const Exposure& exposure) {
  FlipSide side;
  ComputeSide(rgb, ppd, wanted, exposure, ThreadScratch(), side);
  return side;
}

SideScratch& ThreadScratch() {
  thread_local SideScratch scratch;
  return scratch;
}

Plane CombineSides(const FlipSide& ref, const FlipSide& tst, int w, int /*h*/,
                   const RowSpans& wanted) {
  Plane flip(ref.lab.size(), 0.0f);
  CombineSides(ref, tst, w, wanted, flip);
  return flip;
}

// The LDR-FLIP map from the two halves (Andersson et al. 2020, Sec. 4). Row by row, each step
// over the row's span before the next: a pixel's two powf calls (its colour difference's, then
// its error's, which needs the first) waited on each other, and the colour pipeline's ~5 ns per
// call (a quarter of HDR-FLIP's time) was their latency; a step's calls are independent and
// overlap. The same operations on the same floats: the same map.
void CombineSides(const FlipSide& ref, const FlipSide& tst, int w, const RowSpans& wanted,
                  Plane& flip) {
  static const float c_max = MaxColorDifference();
  const float pc_cmax = kPc * c_max;
  flip.resize(ref.lab.size());
  internal::ParallelRows(static_cast<int>(wanted.begin.size()), [&](int begin, int end) {
    std::vector<float> color, exponent;
    for (int y = begin; y < end; ++y) {
      const int x0 = wanted.begin[y], n = wanted.end[y] - x0;
      if (n <= 0) continue;
      const std::size_t first = static_cast<std::size_t>(y) * w + x0;
      color.resize(n);
      exponent.resize(n);
      // Eq. 4-5: HyAB^q_c, remapped so the lower p_c of the range covers [0, p_t]. Both pieces
      // are computed and one kept by a mask, not a branch, so that the loop vectorises.
      for (int j = 0; j < n; ++j) color[j] = HyAB(ref.lab[first + j], tst.lab[first + j]);
      for (int j = 0; j < n; ++j) color[j] = std::pow(color[j], kQc);
      for (int j = 0; j < n; ++j) {
        const float c = color[j];
        const float low = c * (kPt / pc_cmax);
        const float high = kPt + (c - pc_cmax) / (c_max - pc_cmax) * (1.0f - kPt);
        const std::uint32_t keep = 0u - static_cast<std::uint32_t>(c < pc_cmax);
        color[j] = std::bit_cast<float>((std::bit_cast<std::uint32_t>(low) & keep) |
                                        (std::bit_cast<std::uint32_t>(high) & ~keep));
      }
      // Eq. 6: feature difference, max of edge and point differences, normalised by 1/sqrt(2),
      // raised to q_f = 0.5 (a square root).
      static_assert(kQf == 0.5f);
      const float* ref_edge = &ref.features.edge[first];
      const float* tst_edge = &tst.features.edge[first];
      const float* ref_point = &ref.features.point[first];
      const float* tst_point = &tst.features.point[first];
      for (int j = 0; j < n; ++j) {
        exponent[j] = 1.0f - std::sqrt(std::max(std::abs(ref_edge[j] - tst_edge[j]),
                                                std::abs(ref_point[j] - tst_point[j])) /
                                       std::numbers::sqrt2_v<float>);
      }
      // Eq. 7: feature differences amplify the colour error.
      float* out = &flip[first];
      for (int j = 0; j < n; ++j) out[j] = std::pow(color[j], exponent[j]);
    }
  });
}

}  // namespace shadefit::metrics::internal
