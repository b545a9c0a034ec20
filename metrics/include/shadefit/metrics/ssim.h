// Structural similarity: SSIM (Wang, Bovik, Sheikh, Simoncelli 2004, "Image Quality Assessment:
// From Error Visibility to Structural Similarity", IEEE TIP 13(4)) and MS-SSIM (Wang, Simoncelli,
// Bovik 2003, "Multi-Scale Structural Similarity for Image Quality Assessment", Asilomar).
//
// Inputs: any images of equal size and channel count whose values lie in a range of width
// `data_range` (e.g. display-encoded values in [0, 1]: use DisplayEncode / Luminance from
// common.h). No colour conversion happens here: every channel is compared on its own and the
// reported mean is the average of the channel means. For luminance SSIM pass one-channel
// luminance images.
//
// Window and borders: an 11 x 11 Gaussian window (sigma 1.5, 1-D taps exp(-x^2 / 2 sigma^2),
// normalised) applied separably, with the input mirrored at the border ("reflect": d c b a | a b c
// d). As in Wang's reference code and scikit-image, only pixels whose whole window lies inside the
// image (at least `radius` pixels from every edge) are averaged; the returned map still covers the
// whole image. Images smaller than the window on either side are an error.
//
// Masks: the mean is over pixels whose whole window lies inside the image AND inside the mask
// (the mask eroded by the square window), so masked-out content never contributes to a pooled
// value. No such pixel -> NoSsimWindowInMaskError.
#pragma once

#include <array>
#include <vector>

#include "shadefit/base/error.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

// No pixel's whole window lies inside the mask (a small object, or MS-SSIM's coarsest scale):
// its own type so that a caller may fall back to an unmasked comparison without reading the
// message (the study runner does; ComputeMetrics rethrows it as this type).
class NoSsimWindowInMaskError : public Error {
 public:
  using Error::Error;
};

struct SsimParameters {
  // Width of the value range L (max - min possible value); C1 = (K1 L)^2, C2 = (K2 L)^2.
  double data_range = 1.0;
  // K1, K2 of Wang et al. 2004, Eq. 7 and 9.
  double k1 = 0.01;
  double k2 = 0.03;
  // Gaussian window: standard deviation in pixels and radius (window = 2 radius + 1 = 11).
  double sigma = 1.5;
  int radius = 5;
  // Optional single-channel mask, same size; valid where > 0.5 (see header comment).
  const Image* mask = nullptr;
};

struct SsimResult {
  double mean = 0.0;                 // Average of channel_means; 1 for identical images.
  std::vector<double> channel_means; // Mean SSIM per channel over the pooled pixels.
  std::size_t pooled_pixels = 0;     // Pixels averaged (interior, inside the eroded mask).
};

// Mean SSIM (Wang et al. 2004, Eq. 13 with C3 = C2 / 2 and alpha = beta = gamma = 1, i.e.
// SSIM = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 +
// C2)), population (biased) moments under the Gaussian window). If ssim_map is given it
// receives the per-pixel SSIM, one channel per input channel.
SsimResult Ssim(const Image& reference, const Image& test, const SsimParameters& p = {},
                Image* ssim_map = nullptr);

struct MsSsimParameters {
  // Window, constants, data_range and mask of every scale.
  SsimParameters ssim;
  // Exponents beta_j = gamma_j of scales 1..5 (Wang et al. 2003, Sec. 3.2); alpha_5 = beta_5.
  std::array<double, 5> weights = {0.0448, 0.2856, 0.3001, 0.2363, 0.1333};
};

// SSIM's per-pixel terms of one plane at one scale, over a call's window (the frame, or the part
// around its mask): SSIM and its contrast-structure and luminance terms (Wang et al. 2004, Eq. 6
// and 9) at the pixels the call computed, row by row: row y's columns [begin[y], end[y]) are at
// offset[y] onwards. (x0, y0) is the window's corner in the frame's pixels at this scale.
struct SsimPlaneTerms {
  int x0 = 0, y0 = 0, width = 0, height = 0;
  std::vector<int> begin, end;
  std::vector<std::size_t> offset;
  std::vector<double> ssim, cs, luminance;
};

// MS-SSIM's terms on the display luminance (one plane per scale; the first is SSIM's) and SSIM's
// on the display RGB (one plane per channel).
struct SsimTerms {
  std::vector<SsimPlaneTerms> luminance, rgb;
};

struct MsSsimResult {
  double value = 0.0;          // MS-SSIM, average over channels; 1 for identical images.
  int scales_used = 0;         // 5 unless the image is too small (see MsSsim).
  std::vector<double> contrast_structure;  // Mean cs_j per scale (channel average).
  double luminance = 0.0;      // Mean l_M at the coarsest scale used (channel average).
};

// MS-SSIM = l_M^{w_M} * prod_{j=1..M} cs_j^{w_j} (Wang et al. 2003, Eq. 7). Between scales the
// image is filtered with a 2 x 2 box and subsampled by 2 (an odd last row / column is dropped);
// the mask is subsampled by keeping a coarse pixel only if all four fine pixels are valid.
// Small images: M is the number of scales (at most 5) whose shorter side is still >= the window
// (11 px), and the weights of those scales are renormalised to sum to 1 (so 1 still means
// identical); an image smaller than one window is an error. Negative mean cs or l (strongly
// anti-correlated images) are clamped to 0 before the fractional power, giving MS-SSIM 0.
MsSsimResult MsSsim(const Image& reference, const Image& test, const MsSsimParameters& p = {});

}  // namespace shadefit::metrics
