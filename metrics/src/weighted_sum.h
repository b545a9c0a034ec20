// The separable filters' inner loop, shared by FLIP (float) and SSIM (double) (not installed).
#pragma once

#include <cstring>

namespace shadefit::metrics::internal {

// out[x] = sum over k of taps[k] * in(k)[x] for x in [0, n), summed from 0 in the order of k:
// `in(k)` is the k-th tap's input, the row shifted by k for a row pass or the k-th row for a
// column pass. The running sums of 8 vectors of pixels (64 floats, 32 doubles) stay in registers
// while k runs (in the AVX2 build's 16 registers; the baseline's 32-byte vectors are pairs of
// its 16-byte ones and some spill), so each tap loads its inputs once and no sum is loaded or
// stored between taps; adding one tap at a time over the row loaded and stored every sum per
// tap, and 8 independent sums keep the adder busy. Each pixel gets the same multiplies and
// additions in the same order as a sum per pixel, so the same bits. Called from functions built
// for AVX2 and the baseline and chosen at run time (gnu::target_clones): neither enables fused
// multiply-add, which would round differently, so the same bits on every machine. (A build with
// -mfma or a -march that has it would let GCC contract these, as it would the loop before.)
// 32 bytes of T: 8 floats or 4 doubles (a vector attribute on a dependent type is ignored, so
// one specialisation per type).
template <typename T>
struct Vector32;
template <>
struct Vector32<float> {
  using Type = float __attribute__((vector_size(32)));
};
template <>
struct Vector32<double> {
  using Type = double __attribute__((vector_size(32)));
};

template <typename T, int kVectors, typename Input>
[[gnu::always_inline]] inline void WeightedSumBlock(T* out, const T* taps, int ntaps, Input in) {
  using V = typename Vector32<T>::Type;
  constexpr int kLanes = sizeof(V) / sizeof(T);
  V sums[kVectors];
  for (V& sum : sums) sum = V{};
  for (int k = 0; k < ntaps; ++k) {
    const T* p = in(k);
    // The tap in every lane, as an initialiser list the compiler makes one broadcast (written
    // here: a helper function is lowered for the baseline before it is inlined).
    const T tap = taps[k];
    V t;
    if constexpr (kLanes == 8) {
      t = V{tap, tap, tap, tap, tap, tap, tap, tap};
    } else {
      t = V{tap, tap, tap, tap};
    }
    for (int j = 0; j < kVectors; ++j) {
      V v;
      std::memcpy(&v, p + kLanes * j, sizeof v);
      sums[j] += t * v;
    }
  }
  std::memcpy(out, sums, sizeof sums);
}

template <typename T, typename Input>
[[gnu::always_inline]] inline void WeightedSum(T* out, const T* taps, int ntaps, int n,
                                               Input in) {
  constexpr int kLanes = sizeof(typename Vector32<T>::Type) / sizeof(T);
  int x = 0;
  for (; x + 8 * kLanes <= n; x += 8 * kLanes) {
    WeightedSumBlock<T, 8>(out + x, taps, ntaps, [&](int k) { return in(k) + x; });
  }
  for (; x + kLanes <= n; x += kLanes) {
    WeightedSumBlock<T, 1>(out + x, taps, ntaps, [&](int k) { return in(k) + x; });
  }
  for (; x < n; ++x) {
    T sum = T(0);
    for (int k = 0; k < ntaps; ++k) sum += taps[k] * in(k)[x];
    out[x] = sum;
  }
}

}  // namespace shadefit::metrics::internal
