#include "shadefit/metrics/ssim.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "internal.h"
#include "weighted_sum.h"
#include "shadefit/base/error.h"
#include "shadefit/metrics/common.h"

namespace shadefit::metrics {
namespace {

using Plane = std::vector<double>;

// Normalised 1-D Gaussian taps exp(-x^2 / (2 sigma^2)), x in [-radius, radius]. The 2-D window
// of Wang et al. 2004 (11 x 11, sigma 1.5, sum 1) is their outer product.
std::vector<double> GaussianTaps(double sigma, int radius) {
  std::vector<double> taps(2 * radius + 1);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    taps[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
    sum += taps[i + radius];
  }
  for (double& t : taps) t /= sum;
  return taps;
}

// Mirror index "d c b a | a b c d" (the edge sample is repeated); valid while radius <= n.
inline int Reflect(int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); }

// Pixels pooled into the mean: whole window inside the image and inside the mask.
std::vector<std::uint8_t> PoolMask(const std::vector<std::uint8_t>& valid, int w, int h, int r) {
  // Integral image of invalid pixels: a window is usable when it holds none.
  std::vector<int> integral(static_cast<std::size_t>(w + 1) * (h + 1), 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y + 1) * (w + 1) + x + 1;
      integral[i] = (valid[static_cast<std::size_t>(y) * w + x] ? 0 : 1) + integral[i - 1] +
                    integral[i - (w + 1)] - integral[i - (w + 1) - 1];
    }
  }
  std::vector<std::uint8_t> pool(static_cast<std::size_t>(w) * h, 0);
  for (int y = r; y < h - r; ++y) {
    for (int x = r; x < w - r; ++x) {
      const auto at = [&](int xx, int yy) {
        return integral[static_cast<std::size_t>(yy) * (w + 1) + xx];
      };
      const int invalid =
          at(x + r + 1, y + r + 1) - at(x - r, y + r + 1) - at(x + r + 1, y - r) + at(x - r, y - r);
      pool[static_cast<std::size_t>(y) * w + x] = invalid == 0 ? 1 : 0;
    }
  }
  return pool;
}

struct PlaneStats {
  double ssim = 0.0;       // Mean SSIM over pooled pixels.
  double cs = 0.0;         // Mean contrast-structure term.
  double luminance = 0.0;  // Mean luminance term.
};

// The filters' inner loop (weighted_sum.h), built for AVX2 and the baseline. Along a row:
// in(k) = in + k (the row's pixels from the first tap's on).
[[gnu::target_clones("avx2", "default")]] void ConvolveRow(double* out, const double* in,
                                                            const double* taps, int ntaps, int n) {
  internal::WeightedSum(out, taps, ntaps, n, [in](int k) { return in + k; });
}

// Down a column: in(k) = rows[k] (the rows of the taps, from the first's on).
[[gnu::target_clones("avx2", "default")]] void ConvolveColumn(double* out,
                                                               const double* const* rows,
                                                               const double* taps, int ntaps,
                                                               int n) {
  internal::WeightedSum(out, taps, ntaps, n, [rows](int k) { return rows[k]; });
}

// The columns [begin, end) of each row whose SSIM a call computes: all of them when a map is
// written, else per row from the first to the last pooled pixel (begin == end: none).
struct Columns {
  std::vector<int> begin, end;
};

Columns PooledColumns(const std::vector<std::uint8_t>& pool, int w, int h, bool whole) {
  Columns c{std::vector<int>(h, 0), std::vector<int>(h, whole ? w : 0)};
  if (whole) return c;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* row = &pool[static_cast<std::size_t>(y) * w];
    int first = w, last = -1;
    for (int x = 0; x < w; ++x) {
      if (!row[x]) continue;
      first = std::min(first, x);
      last = x;
    }
    if (last >= 0) {
      c.begin[y] = first;
      c.end[y] = last + 1;
    }
  }
  return c;
}

// The columns the vertical pass reads per row: the hull of `c`'s ranges within r rows (mirrored
// at the frame's edges like the rows themselves).
Columns ReadByVerticalPass(const Columns& c, int r) {
  const int h = static_cast<int>(c.begin.size());
  Columns out{std::vector<int>(h, 0), std::vector<int>(h, 0)};
  for (int row = 0; row < h; ++row) {
    if (c.begin[row] >= c.end[row]) continue;
    for (int k = -r; k <= r; ++k) {
      const int read = Reflect(row + k, h);
      if (out.begin[read] >= out.end[read]) {
        out.begin[read] = c.begin[row];
        out.end[read] = c.end[row];
      } else {
        out.begin[read] = std::min(out.begin[read], c.begin[row]);
        out.end[read] = std::max(out.end[read], c.end[row]);
      }
    }
  }
  return out;
}

// SSIM of one plane pair. map (optional) receives SSIM at every pixel with the given stride.
// Without a map only the pooled pixels' windows are computed (the filters' supports around them),
// with the same arithmetic per pixel as over the whole frame: the same bits.
// keep (optional): receives the terms at every pixel computed (its corner is the caller's).
PlaneStats SsimPlane(const Plane& x, const Plane& y, int w, int h,
                     const std::vector<std::uint8_t>& pool, std::size_t pooled,
                     const SsimParameters& p, float* map, int map_stride,
                     SsimPlaneTerms* keep = nullptr) {
  const int r = p.radius;
  const std::vector<double> taps = GaussianTaps(p.sigma, r);
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const Columns wanted = PooledColumns(pool, w, h, map != nullptr);
  const Columns read = ReadByVerticalPass(wanted, r);
  if (keep) {
    keep->width = w;
    keep->height = h;
    keep->begin = wanted.begin;
    keep->end = wanted.end;
    keep->offset.assign(h, 0);
    std::size_t computed = 0;
    for (int row = 0; row < h; ++row) {
      keep->offset[row] = computed;
      computed += static_cast<std::size_t>(std::max(0, wanted.end[row] - wanted.begin[row]));
    }
    keep->ssim.resize(computed);
    keep->cs.resize(computed);
    keep->luminance.resize(computed);
  }
  // Horizontal pass of the five moments x, y, x^2, y^2, xy: five planes of one block, left
  // uninitialised outside the columns this pass writes (the only ones the vertical pass reads).
  // A job computes SSIM hundreds of times; zeroing whole planes cost a fill and a fresh block's
  // pages each time. The written columns start at +0.0, as before (0.0 + -0.0 is +0.0).
  const std::unique_ptr<double[]> block(new double[5 * n]);
  double* const horizontal[5] = {block.get(), block.get() + n, block.get() + 2 * n,
                                 block.get() + 3 * n, block.get() + 4 * n};
  internal::ParallelRows(h, [&](int row_begin, int row_end) {
    std::vector<Plane> padded(5, Plane(w + 2 * r));
    for (int row = row_begin; row < row_end; ++row) {
      const int x0 = read.begin[row], x1 = read.end[row];
      if (x0 >= x1) continue;
      const double* xr = &x[static_cast<std::size_t>(row) * w];
      const double* yr = &y[static_cast<std::size_t>(row) * w];
      // padded[f][j] holds column x0 - r + j, mirrored at the frame's edges.
      for (int i = x0 - r; i < x1 + r; ++i) {
        const int s = Reflect(i, w);
        const int j = i - (x0 - r);
        padded[0][j] = xr[s];
        padded[1][j] = yr[s];
        padded[2][j] = xr[s] * xr[s];
        padded[3][j] = yr[s] * yr[s];
        padded[4][j] = xr[s] * yr[s];
      }
      for (int f = 0; f < 5; ++f) {
        ConvolveRow(&horizontal[f][static_cast<std::size_t>(row) * w + x0], padded[f].data(),
                    taps.data(), 2 * r + 1, x1 - x0);
      }
    }
  });
  // Vertical pass and the SSIM terms, accumulated per row block.
  const double c1 = (p.k1 * p.data_range) * (p.k1 * p.data_range);
  const double c2 = (p.k2 * p.data_range) * (p.k2 * p.data_range);
  std::vector<double> row_ssim(h, 0.0), row_cs(h, 0.0), row_l(h, 0.0);
  internal::ParallelRows(h, [&](int row_begin, int row_end) {
    std::vector<Plane> m(5, Plane(w));
    std::vector<std::size_t> offsets(2 * r + 1);
    std::vector<const double*> rows(2 * r + 1);
    for (int row = row_begin; row < row_end; ++row) {
      const int x0 = wanted.begin[row], x1 = wanted.end[row];
      if (x0 >= x1) continue;
      for (int k = -r; k <= r; ++k) {
        offsets[k + r] = static_cast<std::size_t>(Reflect(row + k, h)) * w + x0;
      }
      for (int f = 0; f < 5; ++f) {
        for (int k = 0; k <= 2 * r; ++k) rows[k] = &horizontal[f][offsets[k]];
        ConvolveColumn(m[f].data(), rows.data(), taps.data(), 2 * r + 1, x1 - x0);
      }
      double sum_ssim = 0.0, sum_cs = 0.0, sum_l = 0.0;
      for (int i = x0; i < x1; ++i) {
        const int j = i - x0;
        const double mx = m[0][j], my = m[1][j];
        const double vx = m[2][j] - mx * mx;  // Population (biased) moments: skimage's
        const double vy = m[3][j] - my * my;  // use_sample_covariance=False, Wang's code.
        const double cxy = m[4][j] - mx * my;
        const double l = (2.0 * mx * my + c1) / (mx * mx + my * my + c1);  // Eq. 6
        const double cs = (2.0 * cxy + c2) / (vx + vy + c2);  // Eq. 9 and 10 with C3 = C2 / 2
        const double s = l * cs;
        const std::size_t index = static_cast<std::size_t>(row) * w + i;
        if (map) map[index * map_stride] = static_cast<float>(s);
        if (keep) {
          const std::size_t k = keep->offset[row] + j;
          keep->ssim[k] = s;
          keep->cs[k] = cs;
          keep->luminance[k] = l;
        }
        if (pool[index]) {
          sum_ssim += s;
          sum_cs += cs;
          sum_l += l;
        }
      }
      row_ssim[row] = sum_ssim;
      row_cs[row] = sum_cs;
      row_l[row] = sum_l;
    }
  });
  PlaneStats stats;
  for (int row = 0; row < h; ++row) {
    stats.ssim += row_ssim[row];
    stats.cs += row_cs[row];
    stats.luminance += row_l[row];
  }
  stats.ssim /= static_cast<double>(pooled);
  stats.cs /= static_cast<double>(pooled);
  stats.luminance /= static_cast<double>(pooled);
  return stats;
}

// SsimPlane's statistics from kept terms: the pooled pixels of a w x h plane whose corner is
// (x0, y0) in the frame, summed per row and then over the rows as SsimPlane sums them. None when
// a pooled pixel has no kept value.
std::optional<PlaneStats> PoolKept(const SsimPlaneTerms& kept, int x0, int y0,
                                   const std::vector<std::uint8_t>& pool, int w, int h,
                                   std::size_t pooled) {
  PlaneStats stats;
  for (int row = 0; row < h; ++row) {
    const int ky = y0 + row - kept.y0;
    double sum_ssim = 0.0, sum_cs = 0.0, sum_l = 0.0;
    for (int i = 0; i < w; ++i) {
      if (!pool[static_cast<std::size_t>(row) * w + i]) continue;
      const int kx = x0 + i - kept.x0;
      if (ky < 0 || ky >= kept.height || kx < kept.begin[ky] || kx >= kept.end[ky]) {
        return std::nullopt;
      }
      const std::size_t k = kept.offset[ky] + (kx - kept.begin[ky]);
      if (std::isnan(kept.ssim[k])) return std::nullopt;
      sum_ssim += kept.ssim[k];
      sum_cs += kept.cs[k];
      sum_l += kept.luminance[k];
    }
    stats.ssim += sum_ssim;
    stats.cs += sum_cs;
    stats.luminance += sum_l;
  }
  stats.ssim /= static_cast<double>(pooled);
  stats.cs /= static_cast<double>(pooled);
  stats.luminance /= static_cast<double>(pooled);
  return stats;
}

// SsimPlane of plane `index` (scale x channels + channel) at `scale`, keeping its terms or
// pooling kept ones as `reuse` says. A window's corner must be a multiple of 2^scale for its
// pixels at the scale to be the frame's; else neither.
PlaneStats ReusingSsimPlane(const Plane& x, const Plane& y, int w, int h,
                            const std::vector<std::uint8_t>& pool, std::size_t pooled,
                            const SsimParameters& p, const internal::SsimReuse& reuse, int scale,
                            std::size_t index) {
  const int step = 1 << scale;
  if (reuse.x0 % step != 0 || reuse.y0 % step != 0) {
    return SsimPlane(x, y, w, h, pool, pooled, p, nullptr, 1);
  }
  const int x0 = reuse.x0 / step, y0 = reuse.y0 / step;
  if (reuse.keep) {
    if (reuse.keep->size() <= index) reuse.keep->resize(index + 1);
    SsimPlaneTerms& keep = (*reuse.keep)[index];
    keep.x0 = x0;
    keep.y0 = y0;
    return SsimPlane(x, y, w, h, pool, pooled, p, nullptr, 1, &keep);
  }
  if (reuse.from && index < reuse.from->size()) {
    const std::optional<PlaneStats> kept =
        PoolKept((*reuse.from)[index], x0, y0, pool, w, h, pooled);
    if (kept) return *kept;
  }
  return SsimPlane(x, y, w, h, pool, pooled, p, nullptr, 1);
}

std::vector<Plane> SplitPlanes(const Image& image) {
  std::vector<Plane> planes(image.channels, Plane(image.PixelCount()));
  for (std::size_t i = 0; i < image.PixelCount(); ++i) {
    for (int c = 0; c < image.channels; ++c) planes[c][i] = image.data[i * image.channels + c];
  }
  return planes;
}

std::vector<std::uint8_t> ValidPixels(const Image* mask, std::size_t n) {
  std::vector<std::uint8_t> valid(n, 1);
  if (mask) {
    for (std::size_t i = 0; i < n; ++i) valid[i] = mask->data[i] > 0.5f ? 1 : 0;
  }
  return valid;
}

void CheckWindowFits(int w, int h, const SsimParameters& p) {
  const int window = 2 * p.radius + 1;
  if (w < window || h < window) {
    throw Error("reference", "resolution",
                std::to_string(w) + "x" + std::to_string(h) + " is smaller than the " +
                    std::to_string(window) + "x" + std::to_string(window) + " SSIM window");
  }
}

std::size_t CountPooled(const std::vector<std::uint8_t>& pool, const SsimParameters& p) {
  std::size_t pooled = 0;
  for (auto v : pool) pooled += v;
  if (pooled == 0) {
    const std::string window = std::to_string(2 * p.radius + 1);
    throw NoSsimWindowInMaskError(
        "mask", "pixels",
        "no pixel whose " + window + "x" + window + " SSIM window lies inside the mask");
  }
  return pooled;
}

// 2 x 2 box filter and subsampling by 2 (Wang et al. 2003, Sec. 3.1); odd edges dropped.
Plane Downsample(const Plane& in, int w, int h) {
  const int w2 = w / 2, h2 = h / 2;
  Plane out(static_cast<std::size_t>(w2) * h2);
  for (int y = 0; y < h2; ++y) {
    for (int x = 0; x < w2; ++x) {
      const std::size_t i = static_cast<std::size_t>(2 * y) * w + 2 * x;
      out[static_cast<std::size_t>(y) * w2 + x] =
          0.25 * (in[i] + in[i + 1] + in[i + w] + in[i + w + 1]);
    }
  }
  return out;
}

std::vector<std::uint8_t> DownsampleValid(const std::vector<std::uint8_t>& in, int w, int h) {
  const int w2 = w / 2, h2 = h / 2;
  std::vector<std::uint8_t> out(static_cast<std::size_t>(w2) * h2);
  for (int y = 0; y < h2; ++y) {
    for (int x = 0; x < w2; ++x) {
      const std::size_t i = static_cast<std::size_t>(2 * y) * w + 2 * x;
      out[static_cast<std::size_t>(y) * w2 + x] = in[i] & in[i + 1] & in[i + w] & in[i + w + 1];
    }
  }
  return out;
}

}  // namespace

namespace {

SsimResult SsimOf(const Image& reference, const Image& test, const SsimParameters& p,
                  Image* ssim_map, const internal::SsimReuse& reuse) {
  ValidateInputs(reference, test, p.mask, 0);
  const int w = reference.width, h = reference.height;
  CheckWindowFits(w, h, p);
  const std::vector<std::uint8_t> pool =
      PoolMask(ValidPixels(p.mask, reference.PixelCount()), w, h, p.radius);
  SsimResult result;
  result.pooled_pixels = CountPooled(pool, p);
  const std::vector<Plane> x = SplitPlanes(reference);
  const std::vector<Plane> y = SplitPlanes(test);
  if (ssim_map) *ssim_map = Image(w, h, reference.channels);
  for (int c = 0; c < reference.channels; ++c) {
    float* map = ssim_map ? ssim_map->data.data() + c : nullptr;
    const PlaneStats stats =
        map ? SsimPlane(x[c], y[c], w, h, pool, result.pooled_pixels, p, map, reference.channels)
            : ReusingSsimPlane(x[c], y[c], w, h, pool, result.pooled_pixels, p, reuse, 0, c);
    result.channel_means.push_back(stats.ssim);
    result.mean += stats.ssim / reference.channels;
  }
  return result;
}

}  // namespace

SsimResult Ssim(const Image& reference, const Image& test, const SsimParameters& p,
                Image* ssim_map) {
  return SsimOf(reference, test, p, ssim_map, {});
}

SsimResult internal::SsimReusing(const Image& reference, const Image& test,
                                 const SsimParameters& p, const SsimReuse& reuse) {
  return SsimOf(reference, test, p, nullptr, reuse);
}

MsSsimResult MsSsim(const Image& reference, const Image& test, const MsSsimParameters& p) {
  return internal::MsSsimAndSsim(reference, test, p, nullptr);
}

namespace internal {

MsSsimResult MsSsimAndSsim(const Image& reference, const Image& test, const MsSsimParameters& p,
                           SsimResult* ssim, const SsimReuse& reuse) {
  ValidateInputs(reference, test, p.ssim.mask, 0);
  int w = reference.width, h = reference.height;
  CheckWindowFits(w, h, p.ssim);
  // Number of scales whose shorter side still holds a window.
  const int window = 2 * p.ssim.radius + 1;
  int scales = 1;
  while (scales < static_cast<int>(p.weights.size()) && std::min(w, h) >> scales >= window) {
    ++scales;
  }
  std::vector<std::uint8_t> valid = ValidPixels(p.ssim.mask, reference.PixelCount());
  if (p.ssim.mask) {
    // A mask shrinks at every scale (window erosion, then 2x2 downsampling): keep only the
    // scales where some window still lies inside it, as for small images above. Scale 0 must
    // have one, or CountPooled reports the mask as unusable.
    std::vector<std::uint8_t> v = valid;
    int sw = w, sh = h, usable = 0;
    for (int j = 0; j < scales; ++j) {
      const std::vector<std::uint8_t> pool = PoolMask(v, sw, sh, p.ssim.radius);
      if (std::find(pool.begin(), pool.end(), 1) == pool.end()) break;
      ++usable;
      v = DownsampleValid(v, sw, sh);
      sw /= 2;
      sh /= 2;
    }
    scales = std::max(usable, 1);
  }
  double weight_sum = 0.0;
  for (int j = 0; j < scales; ++j) weight_sum += p.weights[j];

  std::vector<Plane> x = SplitPlanes(reference);
  std::vector<Plane> y = SplitPlanes(test);
  const int channels = reference.channels;
  MsSsimResult result;
  result.scales_used = scales;
  std::vector<double> log_value(channels, 0.0);  // Sum of w_j log(term), per channel.
  std::vector<bool> zero(channels, false);
  for (int j = 0; j < scales; ++j) {
    const std::vector<std::uint8_t> pool = PoolMask(valid, w, h, p.ssim.radius);
    const std::size_t pooled = CountPooled(pool, p.ssim);
    const double weight = p.weights[j] / weight_sum;
    double cs_mean = 0.0, l_mean = 0.0;
    for (int c = 0; c < channels; ++c) {
      const PlaneStats stats = ReusingSsimPlane(x[c], y[c], w, h, pool, pooled, p.ssim, reuse, j,
                                                static_cast<std::size_t>(j) * channels + c);
      if (j == 0 && ssim != nullptr) {  // Ssim's own arithmetic (same planes, pool, order).
        if (c == 0) *ssim = SsimResult{0.0, {}, pooled};
        ssim->channel_means.push_back(stats.ssim);
        ssim->mean += stats.ssim / channels;
      }
      cs_mean += stats.cs / channels;
      l_mean += stats.luminance / channels;
      // Clamp negative means to 0: a fractional power of a negative number is undefined.
      double term = std::max(0.0, stats.cs);
      if (j == scales - 1) term *= std::max(0.0, stats.luminance);  // l_M at the last scale.
      if (term <= 0.0) {
        zero[c] = true;
      } else {
        log_value[c] += weight * std::log(term);
      }
    }
    result.contrast_structure.push_back(cs_mean);
    if (j == scales - 1) {
      result.luminance = l_mean;
      break;
    }
    for (int c = 0; c < channels; ++c) {
      x[c] = Downsample(x[c], w, h);
      y[c] = Downsample(y[c], w, h);
    }
    valid = DownsampleValid(valid, w, h);
    w /= 2;
    h /= 2;
  }
  for (int c = 0; c < channels; ++c) {
    result.value += (zero[c] ? 0.0 : std::exp(log_value[c])) / channels;
  }
  return result;
}

}  // namespace internal
}  // namespace shadefit::metrics
