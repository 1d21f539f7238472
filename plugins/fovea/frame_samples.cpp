#include "frame_samples.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "saccade/simd.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace saccade::fovea {

namespace {

// OpenCV's fixed point (imgwarp.cpp): the map's products in 1/1024 pixel, an
// output pixel's source position in 1/32 pixel (5 bits between pixels), the
// bilinear weights (32 - f) and f along each axis, whose products sum to
// 1024. (OpenCV keeps them times 32 as 15-bit numbers; the rounded results
// are the same.) Its BGR to gray is the 15-bit one.
constexpr int kMapScale = 1024, kSubpixelBits = 5, kSubpixels = 1 << kSubpixelBits;
constexpr int kGrayB = 3735, kGrayG = 19235, kGrayR = 9798, kGrayShift = 15;

// An output pixel from its source position X, Y (in 1/32 pixel), the frame's
// border replicated: of an 8-bit BGR frame (`Channels` 3) its gray, of a
// monochrome one (1) its value.
template <int Channels = 3>
[[maybe_unused]] uchar warp_pixel(const cv::Mat& frame, int x_fixed, int y_fixed) {
  const int sx = x_fixed >> kSubpixelBits, sy = y_fixed >> kSubpixelBits;
  const int fx = x_fixed & (kSubpixels - 1), fy = y_fixed & (kSubpixels - 1);
  const int x0 = std::clamp(sx, 0, frame.cols - 1), x1 = std::clamp(sx + 1, 0, frame.cols - 1);
  const uchar* r0 = frame.ptr<uchar>(std::clamp(sy, 0, frame.rows - 1));
  const uchar* r1 = frame.ptr<uchar>(std::clamp(sy + 1, 0, frame.rows - 1));
  const int w00 = (kSubpixels - fy) * (kSubpixels - fx), w01 = (kSubpixels - fy) * fx;
  const int w10 = fy * (kSubpixels - fx), w11 = fy * fx;
  int c[3];
  for (int k = 0; k < Channels; ++k)
    c[k] = (r0[Channels * x0 + k] * w00 + r0[Channels * x1 + k] * w01 + r1[Channels * x0 + k] * w10 +
            r1[Channels * x1 + k] * w11 + 512) >>
           10;
  if constexpr (Channels == 1) return static_cast<uchar>(c[0]);
  return static_cast<uchar>((c[0] * kGrayB + c[1] * kGrayG + c[2] * kGrayR + (1 << (kGrayShift - 1))) >> kGrayShift);
}

#if defined(__x86_64__)

// One channel of eight pixels from its taps' 16-bit pairs (the low byte of
// each), weighed and rounded as OpenCV does.
__attribute__((target("avx2"), always_inline)) inline __m256i weighted_channel(__m256i left, __m256i right,
                                                                               __m256i w_left, __m256i w_right,
                                                                               __m256i low_bytes, __m256i half) {
  const __m256i sum = _mm256_add_epi32(_mm256_madd_epi16(_mm256_and_si256(left, low_bytes), w_left),
                                       _mm256_madd_epi16(_mm256_and_si256(right, low_bytes), w_right));
  return _mm256_srai_epi32(_mm256_add_epi32(sum, half), 10);
}

// Eight pixels' bytes and their right neighbours' from one read a pixel,
// gathered: a BGR frame's six bytes in eight (two gathers of four, then
// each pixel's B, G, R shuffled out as a 32-bit lane, the fourth byte zero;
// a BGRA frame's likewise), a monochrome frame's two in four (its value in
// a lane's low byte).
// `offsets`: the pixels' byte offsets from `data`.
template <int Channels>
__attribute__((target("avx2"), always_inline)) inline void gather_pairs(const uchar* data, __m256i offsets,
                                                                        __m256i& pixel, __m256i& next) {
  if constexpr (Channels == 1) {
    pixel = _mm256_i32gather_epi32(reinterpret_cast<const int*>(data), offsets, 1);
    next = _mm256_srli_epi32(pixel, 8);
  } else {
    const auto* base = reinterpret_cast<const long long*>(data);
    // Lanes 0, 1, 4, 5 read by one gather, 2, 3, 6, 7 by the other, so that
    // unpacking their 64-bit halves puts the eight back in order.
    const __m256i ordered = _mm256_permutevar8x32_epi32(offsets, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
    // Per 128 bits (two pixels' reads): their B, G, R, then their neighbours'.
    constexpr char n = Channels;  // where a read's neighbour starts
    const __m256i split = _mm256_setr_epi8(0, 1, 2, -1, 8, 9, 10, -1, n, n + 1, n + 2, -1, 8 + n, 9 + n, 10 + n, -1, 0,
                                           1, 2, -1, 8, 9, 10, -1, n, n + 1, n + 2, -1, 8 + n, 9 + n, 10 + n, -1);
    const __m256i a = _mm256_shuffle_epi8(_mm256_i32gather_epi64(base, _mm256_castsi256_si128(ordered), 1), split);
    const __m256i b = _mm256_shuffle_epi8(_mm256_i32gather_epi64(base, _mm256_extracti128_si256(ordered, 1), 1), split);
    pixel = _mm256_unpacklo_epi64(a, b);
    next = _mm256_unpackhi_epi64(a, b);
  }
}

// One output row, eight pixels a step: `x_step`, `y_step` are the map's
// per-column moves (1/1024 pixel), `x_start`, `y_start` the row's start with
// OpenCV's rounding half added. Reads stay below `frame.datalimit`: a group
// whose reads would not is done pixel by pixel. `Channels`: 3, a BGR frame's
// gray; 1, a monochrome frame's values.
template <int Channels = 3>
__attribute__((target("avx2"))) void warp_row_avx2(const cv::Mat& frame, const int* x_step, const int* y_step,
                                                   int x_start, int y_start, int width, uchar* out) {
  const __m256i zero = _mm256_setzero_si256(), one = _mm256_set1_epi32(1), last_sub = _mm256_set1_epi32(kSubpixels - 1);
  const __m256i subpixels = _mm256_set1_epi32(kSubpixels);
  const __m256i last_x = _mm256_set1_epi32(frame.cols - 1), last_y = _mm256_set1_epi32(frame.rows - 1);
  const __m256i row_bytes = _mm256_set1_epi32(static_cast<int>(frame.step[0]));
  const __m256i low_bytes = _mm256_set1_epi32(0x00FF00FF), half = _mm256_set1_epi32(512);
  const __m256i gray_bg = _mm256_set1_epi32(kGrayB | (kGrayG << 16)), gray_r = _mm256_set1_epi32(kGrayR);
  const __m256i gray_half = _mm256_set1_epi32(1 << (kGrayShift - 1));
  // The last offset a pair of taps' read may start at.
  const __m256i last_read = _mm256_set1_epi32(static_cast<int>(frame.datalimit - frame.data) - (Channels == 1 ? 4 : 8));
  int x = 0;
  for (; x + 8 <= width; x += 8) {
    const __m256i fixed_x = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_set1_epi32(x_start), _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x_step + x))),
        10 - kSubpixelBits);
    const __m256i fixed_y = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_set1_epi32(y_start), _mm256_loadu_si256(reinterpret_cast<const __m256i*>(y_step + x))),
        10 - kSubpixelBits);
    const __m256i sx = _mm256_srai_epi32(fixed_x, kSubpixelBits), sy = _mm256_srai_epi32(fixed_y, kSubpixelBits);
    const __m256i fx = _mm256_and_si256(fixed_x, last_sub), fy = _mm256_and_si256(fixed_y, last_sub);
    const __m256i x0 = _mm256_min_epi32(_mm256_max_epi32(sx, zero), last_x);
    const __m256i x1 = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(sx, one), zero), last_x);
    const __m256i y0 = _mm256_min_epi32(_mm256_max_epi32(sy, zero), last_y);
    const __m256i y1 = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(sy, one), zero), last_y);
    const __m256i left = Channels == 1 ? x0 : _mm256_add_epi32(_mm256_add_epi32(x0, x0), x0);
    const __m256i top = _mm256_add_epi32(_mm256_mullo_epi32(y0, row_bytes), left);
    const __m256i bottom = _mm256_add_epi32(_mm256_mullo_epi32(y1, row_bytes), left);
    if (_mm256_movemask_epi8(_mm256_cmpgt_epi32(bottom, last_read))) {
      for (int k = 0; k < 8; ++k)
        out[x + k] = warp_pixel<Channels>(frame, (x_start + x_step[x + k]) >> (10 - kSubpixelBits),
                                          (y_start + y_step[x + k]) >> (10 - kSubpixelBits));
      continue;
    }
    // Each tap's B, G, R (and a zero byte) as one 32-bit lane; of a
    // monochrome frame, its value and bytes beyond, unused.
    // (At the frame's left and right edges the right tap is the left one.)
    const __m256i same = _mm256_cmpeq_epi32(x0, x1);
    __m256i p00, p01, p10, p11;
    gather_pairs<Channels>(frame.data, top, p00, p01);
    gather_pairs<Channels>(frame.data, bottom, p10, p11);
    p01 = _mm256_blendv_epi8(p01, p00, same);
    p11 = _mm256_blendv_epi8(p11, p10, same);
    // Weights as 16-bit pairs: (w00, w10) for the left taps, (w01, w11) for the right ones.
    const __m256i fy_pair = _mm256_or_si256(_mm256_sub_epi32(subpixels, fy), _mm256_slli_epi32(fy, 16));
    const __m256i rest_x = _mm256_sub_epi32(subpixels, fx);
    const __m256i w_left = _mm256_mullo_epi16(fy_pair, _mm256_or_si256(rest_x, _mm256_slli_epi32(rest_x, 16)));
    const __m256i w_right = _mm256_mullo_epi16(fy_pair, _mm256_or_si256(fx, _mm256_slli_epi32(fx, 16)));
    // Left taps as (B00 G00, B10 G10) and (R00 -, R10 -) 16-bit pairs; right taps likewise.
    const __m256i left_bg = _mm256_blend_epi16(p00, _mm256_slli_epi32(p10, 16), 0xAA);
    const __m256i left_r = _mm256_blend_epi16(_mm256_srli_epi32(p00, 16), p10, 0xAA);
    const __m256i right_bg = _mm256_blend_epi16(p01, _mm256_slli_epi32(p11, 16), 0xAA);
    const __m256i right_r = _mm256_blend_epi16(_mm256_srli_epi32(p01, 16), p11, 0xAA);
    const __m256i b = weighted_channel(left_bg, right_bg, w_left, w_right, low_bytes, half);
    if constexpr (Channels == 1) {
      const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(b, b), zero);
      const int first = _mm256_extract_epi32(bytes, 0), second = _mm256_extract_epi32(bytes, 4);
      std::memcpy(out + x, &first, 4);
      std::memcpy(out + x + 4, &second, 4);
      continue;
    }
    const __m256i g = weighted_channel(_mm256_srli_epi32(left_bg, 8), _mm256_srli_epi32(right_bg, 8), w_left, w_right,
                                       low_bytes, half);
    const __m256i r = weighted_channel(left_r, right_r, w_left, w_right, low_bytes, half);
    const __m256i gray = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_add_epi32(_mm256_madd_epi16(_mm256_or_si256(b, _mm256_slli_epi32(g, 16)), gray_bg),
                                          _mm256_madd_epi16(r, gray_r)),
                         gray_half),
        kGrayShift);
    const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(gray, gray), zero);
    const int first = _mm256_extract_epi32(bytes, 0), second = _mm256_extract_epi32(bytes, 4);
    std::memcpy(out + x, &first, 4);
    std::memcpy(out + x + 4, &second, 4);
  }
  for (; x < width; ++x)
    out[x] = warp_pixel<Channels>(frame, (x_start + x_step[x]) >> (10 - kSubpixelBits),
                                  (y_start + y_step[x]) >> (10 - kSubpixelBits));
}

// An upright map (no turn) reads the same columns on every row: the left and
// right taps of each eight output pixels lie in one window of 128 bytes of a
// source row, and a byte permutation made once per warp picks their B, G, R
// (of a monochrome frame, their value) out of it (AVX-512 VBMI), where the
// eight-pixel path gathers each tap. Sixteen pixels a step: their taps in one
// window (a BGR frame's at steps up to 2.6 source pixels, a monochrome one's
// up to 8.4) or in two, one per eight.
struct UprightGroup {
  std::array<int, 2> window;       // each half's window's first byte in a row
  bool split;                      // the halves' windows differ
  alignas(64) uint8_t left[64];    // lane i's first bytes: its left tap's B, G, R (or value) in its half's window
  alignas(64) uint8_t right[64];   // ... its right tap's
  alignas(64) int32_t rest_x[16];  // 32 - its horizontal weight
};

// The groups of an upright map's output columns, or false where eight
// pixels' taps span more than a window (a step over 5.7 source pixels of a
// BGR frame, 18 of a monochrome one) or the width is not a multiple of sixteen.
template <int Channels>
bool upright_groups(const cv::Mat& frame, const int* x_step, int x_start, int width, std::vector<UprightGroup>& out) {
  if (width % 16 != 0) return false;
  out.resize(static_cast<std::size_t>(width / 16));
  std::array<int, 16> x0, x1;
  for (int g = 0; g < width / 16; ++g) {
    UprightGroup& group = out[static_cast<std::size_t>(g)];
    for (int i = 0; i < 16; ++i) {
      const int fixed = (x_start + x_step[16 * g + i]) >> (10 - kSubpixelBits);
      const int sx = fixed >> kSubpixelBits;
      x0[static_cast<std::size_t>(i)] = std::clamp(sx, 0, frame.cols - 1);
      x1[static_cast<std::size_t>(i)] = std::clamp(sx + 1, 0, frame.cols - 1);
      group.rest_x[i] = kSubpixels - (fixed & (kSubpixels - 1));
    }
    // (Columns only move right along an upright map's row: its first and last taps bound a group.)
    group.split = Channels * (x1[15] - x0[0]) + Channels > 128;
    group.window = {Channels * x0[0], Channels * x0[group.split ? 8 : 0]};
    for (int i = 0; i < 16; ++i) {
      const int from = group.window[i < 8 ? 0 : 1];
      const int left = Channels * x0[static_cast<std::size_t>(i)] - from;
      const int right = Channels * x1[static_cast<std::size_t>(i)] - from;
      if (left < 0 || right + Channels > 128) return false;
      for (int k = 0; k < 4; ++k) {  // (the bytes past a tap's channels are never weighed)
        group.left[4 * i + k] = static_cast<uint8_t>(k < Channels ? left + k : 0);
        group.right[4 * i + k] = static_cast<uint8_t>(k < Channels ? right + k : 0);
      }
    }
  }
  return true;
}

#define SACCADE_AVX512_VBMI __attribute__((target("avx512f,avx512bw,avx512vbmi")))

// The 128 bytes from `at`, those past the frame's data read as zeros.
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline void window_of(const cv::Mat& frame, const uchar* at,
                                                                         __m512i& first, __m512i& second) {
  const std::ptrdiff_t readable = frame.datalimit - at;
  if (readable >= 128) {
    first = _mm512_loadu_si512(at), second = _mm512_loadu_si512(at + 64);
    return;
  }
  const auto mask = [](std::ptrdiff_t n) {
    return n >= 64 ? ~__mmask64{0} : n <= 0 ? __mmask64{0} : (__mmask64{1} << n) - 1;
  };
  first = _mm512_maskz_loadu_epi8(mask(readable), at);
  second = _mm512_maskz_loadu_epi8(mask(readable - 64), at + 64);
}

// A row's left and right taps of a group, each as B, G, R in a 32-bit lane.
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline void taps_of(const cv::Mat& frame, const uchar* row,
                                                                       const UprightGroup& group, __m512i left_index,
                                                                       __m512i right_index, __m512i& left,
                                                                       __m512i& right) {
  __m512i a0, a1;
  window_of(frame, row + group.window[0], a0, a1);
  left = _mm512_permutex2var_epi8(a0, left_index, a1);
  right = _mm512_permutex2var_epi8(a0, right_index, a1);
  if (!group.split) return;
  __m512i b0, b1;
  window_of(frame, row + group.window[1], b0, b1);
  constexpr __mmask16 kSecondHalf = 0xFF00;
  left = _mm512_mask_blend_epi32(kSecondHalf, left, _mm512_permutex2var_epi8(b0, left_index, b1));
  right = _mm512_mask_blend_epi32(kSecondHalf, right, _mm512_permutex2var_epi8(b0, right_index, b1));
}

// weighted_channel, sixteen pixels wide.
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline __m512i weighted_channel16(__m512i left, __m512i right,
                                                                                     __m512i w_left, __m512i w_right) {
  const __m512i low_bytes = _mm512_set1_epi32(0x00FF00FF);
  const __m512i sum = _mm512_add_epi32(_mm512_madd_epi16(_mm512_and_si512(left, low_bytes), w_left),
                                       _mm512_madd_epi16(_mm512_and_si512(right, low_bytes), w_right));
  return _mm512_srai_epi32(_mm512_add_epi32(sum, _mm512_set1_epi32(512)), 10);
}

// Sixteen output pixels from their four taps (each B, G, R, or a monochrome
// frame's value, in a 32-bit lane: top-left, top-right, bottom-left,
// bottom-right), their horizontal weights (32 - fx, fx) and their vertical
// ones as (32 - fy, fy) 16-bit pairs: warp_row_avx2's arithmetic, sixteen
// lanes wide.
template <int Channels>
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline __m512i gray_of_taps(__m512i p00, __m512i p01, __m512i p10,
                                                                               __m512i p11, __m512i rest_x, __m512i fx,
                                                                               __m512i fy_pair) {
  const __m512i gray_bg = _mm512_set1_epi32(kGrayB | (kGrayG << 16)), gray_r = _mm512_set1_epi32(kGrayR);
  const __m512i gray_half = _mm512_set1_epi32(1 << (kGrayShift - 1));
  constexpr __mmask32 kHigh = 0xAAAAAAAA;  // each lane's high 16-bit word
  const __m512i w_left = _mm512_mullo_epi16(fy_pair, _mm512_or_si512(rest_x, _mm512_slli_epi32(rest_x, 16)));
  const __m512i w_right = _mm512_mullo_epi16(fy_pair, _mm512_or_si512(fx, _mm512_slli_epi32(fx, 16)));
  const __m512i left_bg = _mm512_mask_blend_epi16(kHigh, p00, _mm512_slli_epi32(p10, 16));
  const __m512i left_r = _mm512_mask_blend_epi16(kHigh, _mm512_srli_epi32(p00, 16), p10);
  const __m512i right_bg = _mm512_mask_blend_epi16(kHigh, p01, _mm512_slli_epi32(p11, 16));
  const __m512i right_r = _mm512_mask_blend_epi16(kHigh, _mm512_srli_epi32(p01, 16), p11);
  const __m512i blue = weighted_channel16(left_bg, right_bg, w_left, w_right);
  if constexpr (Channels == 1) return blue;
  const __m512i green =
      weighted_channel16(_mm512_srli_epi32(left_bg, 8), _mm512_srli_epi32(right_bg, 8), w_left, w_right);
  const __m512i red = weighted_channel16(left_r, right_r, w_left, w_right);
  const __m512i gray = _mm512_srai_epi32(
      _mm512_add_epi32(_mm512_add_epi32(_mm512_madd_epi16(_mm512_or_si512(blue, _mm512_slli_epi32(green, 16)), gray_bg),
                                        _mm512_madd_epi16(red, gray_r)),
                       gray_half),
      kGrayShift);
  return gray;
}

// One output row of an upright map from source rows `top` and `bottom` at
// vertical weight `fy`: warp_row_avx2's arithmetic, sixteen pixels a step.
template <int Channels>
SACCADE_AVX512_VBMI void upright_row_avx512(const cv::Mat& frame, const std::vector<UprightGroup>& groups,
                                            const uchar* top, const uchar* bottom, int fy, uchar* out) {
  const __m512i subpixels = _mm512_set1_epi32(kSubpixels);
  const __m512i fy_pair = _mm512_set1_epi32((kSubpixels - fy) | (fy << 16));
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const UprightGroup& group = groups[g];
    const __m512i left_index = _mm512_load_si512(group.left), right_index = _mm512_load_si512(group.right);
    // Each tap's B, G, R (and a byte unused) as one 32-bit lane, as warp_row_avx2's gathers give them.
    __m512i p00, p01, p10, p11;
    taps_of(frame, top, group, left_index, right_index, p00, p01);
    taps_of(frame, bottom, group, left_index, right_index, p10, p11);
    const __m512i rest_x = _mm512_load_si512(group.rest_x);
    const __m512i gray =
        gray_of_taps<Channels>(p00, p01, p10, p11, rest_x, _mm512_sub_epi32(subpixels, rest_x), fy_pair);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 16 * g), _mm512_cvtepi32_epi8(gray));
  }
}

// A turned map's row (or an upright one's beyond upright_groups' windows),
// sixteen pixels a step: each of a pixel's two source rows read once for
// its left and right taps together (a BGR frame's six bytes in eight, a
// monochrome frame's two in four), gathered, then permuted apart:
// warp_row_avx2's taps, gray_of_taps's arithmetic. Half the gathered
// elements of warp_row_avx2's four taps; a window of each source row the
// pixels cross, permuted as upright_row_avx512 does, was measured no faster
// over the rows a turn spans (docs/performance.md).
template <int Channels>
SACCADE_AVX512_VBMI void gathered_row_avx512(const cv::Mat& frame, const int* x_step, const int* y_step, int x_start,
                                             int y_start, int width, uchar* out) {
  const __m512i zero = _mm512_setzero_si512(), one = _mm512_set1_epi32(1), last_sub = _mm512_set1_epi32(kSubpixels - 1);
  const __m512i subpixels = _mm512_set1_epi32(kSubpixels);
  const __m512i last_x = _mm512_set1_epi32(frame.cols - 1), last_y = _mm512_set1_epi32(frame.rows - 1);
  const __m512i row_bytes = _mm512_set1_epi32(static_cast<int>(frame.step[0]));
  constexpr int kRead = Channels == 1 ? 4 : 8;
  const __m512i last_read = _mm512_set1_epi32(static_cast<int>(frame.datalimit - frame.data) - kRead);
  // (A BGR frame's) lane i's B, G, R in the two reads' 128 bytes (lanes 0-7
  // the first read's eight qwords), and how far on its right tap's lie.
  const __m512i left_bytes = _mm512_add_epi32(
      _mm512_mullo_epi32(_mm512_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56, 64, 72, 80, 88, 96, 104, 112, 120),
                         _mm512_set1_epi32(0x010101)),
      _mm512_set1_epi32(0x020100));
  const __m512i next_pixel = _mm512_set1_epi32(0x030303);
  int x = 0;
  for (; x + 16 <= width; x += 16) {
    const __m512i fixed_x = _mm512_srai_epi32(
        _mm512_add_epi32(_mm512_set1_epi32(x_start), _mm512_loadu_si512(x_step + x)), 10 - kSubpixelBits);
    const __m512i fixed_y = _mm512_srai_epi32(
        _mm512_add_epi32(_mm512_set1_epi32(y_start), _mm512_loadu_si512(y_step + x)), 10 - kSubpixelBits);
    const __m512i sx = _mm512_srai_epi32(fixed_x, kSubpixelBits), sy = _mm512_srai_epi32(fixed_y, kSubpixelBits);
    const __m512i x0 = _mm512_min_epi32(_mm512_max_epi32(sx, zero), last_x);
    const __m512i x1 = _mm512_min_epi32(_mm512_max_epi32(_mm512_add_epi32(sx, one), zero), last_x);
    const __m512i y0 = _mm512_min_epi32(_mm512_max_epi32(sy, zero), last_y);
    const __m512i y1 = _mm512_min_epi32(_mm512_max_epi32(_mm512_add_epi32(sy, one), zero), last_y);
    const __m512i left = Channels == 1 ? x0 : _mm512_add_epi32(_mm512_add_epi32(x0, x0), x0);
    const __m512i top = _mm512_add_epi32(_mm512_mullo_epi32(y0, row_bytes), left);
    const __m512i bottom = _mm512_add_epi32(_mm512_mullo_epi32(y1, row_bytes), left);
    if (_mm512_cmpgt_epi32_mask(bottom, last_read)) {
      warp_row_avx2<Channels>(frame, x_step + x, y_step + x, x_start, y_start, 16, out + x);
      continue;
    }
    // (At the frame's left and right edges the right tap is the left one.)
    const __mmask16 apart = _mm512_cmpneq_epi32_mask(x1, x0);
    __m512i p00, p01, p10, p11;
    if constexpr (Channels == 1) {
      const int* base = reinterpret_cast<const int*>(frame.data);
      p00 = _mm512_i32gather_epi32(top, base, 1);
      p10 = _mm512_i32gather_epi32(bottom, base, 1);
      p01 = _mm512_mask_srli_epi32(p00, apart, p00, 8);
      p11 = _mm512_mask_srli_epi32(p10, apart, p10, 8);
    } else {
      const auto* base = reinterpret_cast<const long long*>(frame.data);
      const __m512i right_bytes = _mm512_mask_add_epi32(left_bytes, apart, left_bytes, next_pixel);
      const __m512i t0 = _mm512_i32gather_epi64(_mm512_castsi512_si256(top), base, 1);
      const __m512i t1 = _mm512_i32gather_epi64(_mm512_extracti64x4_epi64(top, 1), base, 1);
      const __m512i b0 = _mm512_i32gather_epi64(_mm512_castsi512_si256(bottom), base, 1);
      const __m512i b1 = _mm512_i32gather_epi64(_mm512_extracti64x4_epi64(bottom, 1), base, 1);
      p00 = _mm512_permutex2var_epi8(t0, left_bytes, t1), p01 = _mm512_permutex2var_epi8(t0, right_bytes, t1);
      p10 = _mm512_permutex2var_epi8(b0, left_bytes, b1), p11 = _mm512_permutex2var_epi8(b0, right_bytes, b1);
    }
    const __m512i fx = _mm512_and_si512(fixed_x, last_sub), fy = _mm512_and_si512(fixed_y, last_sub);
    const __m512i fy_pair = _mm512_or_si512(_mm512_sub_epi32(subpixels, fy), _mm512_slli_epi32(fy, 16));
    const __m512i gray = gray_of_taps<Channels>(p00, p01, p10, p11, _mm512_sub_epi32(subpixels, fx), fx, fy_pair);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + x), _mm512_cvtepi32_epi8(gray));
  }
  if (x < width) warp_row_avx2<Channels>(frame, x_step + x, y_step + x, x_start, y_start, width - x, out + x);
}

#else

template <int Channels = 3>
void warp_row_avx2(const cv::Mat&, const int*, const int*, int, int, int, uchar*) {}

#endif

// Whether every byte offset into the frame's data fits the 32-bit lanes the
// eight-pixel paths compute them in (with room to add a row or two).
bool offsets_fit_lanes(const cv::Mat& frame) {
  return frame.datalimit - frame.data < std::numeric_limits<int>::max() / 2;
}

bool avx2_here() {
#if defined(__x86_64__)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
#else
  return false;
#endif
}

// Where a quarter point of a cell falls between two source pixels along one
// axis: the first pixel and the weight of the second.
struct Tap {
  int first;
  float weight;
};

// The taps of the quarter points (-1/4 and +1/4 of a step either side of
// each cell's centre) of `count` cells centred on `center` + (i - middle)
// `step` along an axis of `length` pixels (clamped inside it, as the
// frame's border is replicated).
void quarter_taps(double center, double step, int count, int length, Tap* out) {
  const double middle = (count - 1) / 2.0;
  for (int i = 0; i < count; ++i) {
    const double at = center + (i - middle) * step;
    for (int q = 0; q < 2; ++q) {
      const double s = std::clamp(at + (q == 0 ? -0.25 : 0.25) * step, 0.0, length - 1.001);
      const int first = static_cast<int>(s);
      out[2 * i + q] = {first, static_cast<float>(s - first)};
    }
  }
}

// The gray of a pixel of an 8-bit frame of `Channels` channels (BGR order).
template <int Channels>
float pixel_gray(const uchar* p) {
  if constexpr (Channels == 1)
    return static_cast<float>(p[0]);
  else
    return 0.114f * p[0] + 0.587f * p[1] + 0.299f * p[2];
}

// Cell i of row j: the mean of four bilinear samples at its quarter points.
template <int Channels>
float cell_mean(const cv::Mat& frame, const Tap* tx, const Tap* ty) {
  float total = 0;
  for (int qy = 0; qy < 2; ++qy) {
    const uchar* r0 = frame.ptr<uchar>(ty[qy].first);
    const uchar* r1 = frame.ptr<uchar>(ty[qy].first + 1);
    const float ay = ty[qy].weight;
    for (int qx = 0; qx < 2; ++qx) {
      const int x = tx[qx].first * Channels;
      const float ax = tx[qx].weight;
      const float top = (1 - ax) * pixel_gray<Channels>(r0 + x) + ax * pixel_gray<Channels>(r0 + x + Channels);
      const float bottom = (1 - ax) * pixel_gray<Channels>(r1 + x) + ax * pixel_gray<Channels>(r1 + x + Channels);
      total += (1 - ay) * top + ay * bottom;
    }
  }
  return total * 0.25f;
}

#if defined(__x86_64__)
// The gray of eight pixels whose first bytes `bytes` holds, a pixel a lane;
// the same products and sums, in the same order, as pixel_gray.
template <int Channels>
__attribute__((target("avx2"), always_inline)) inline __m256 lanes_gray(__m256i bytes) {
  const __m256i low = _mm256_set1_epi32(0xFF);
  if constexpr (Channels == 1) {
    return _mm256_cvtepi32_ps(_mm256_and_si256(bytes, low));
  } else {
    const __m256 b = _mm256_cvtepi32_ps(_mm256_and_si256(bytes, low));
    const __m256 g = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(bytes, 8), low));
    const __m256 r = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(bytes, 16), low));
    return _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(0.114f), b), _mm256_mul_ps(_mm256_set1_ps(0.587f), g)),
        _mm256_mul_ps(_mm256_set1_ps(0.299f), r));
  }
}

// A row of cells, eight a step, each lane computed as cell_mean computes one
// (bit for bit: the same float operations in the same order, no fused ones).
// `offset[q]` and `weight[q]` hold each cell's quarter tap q along the row
// (byte offset, weight). A group whose reads (a pixel and the next one) would pass the
// frame's data is done cell by cell.
template <int Channels>
__attribute__((target("avx2"))) void cell_row_avx2(const cv::Mat& frame, const Tap* cols, const int* const offset[2],
                                                   const float* const weight[2], const Tap* ty, int width, float* out) {
  const std::ptrdiff_t last_read = frame.datalimit - frame.data - 4;
  // (The lowest row and the farthest tap are found, not assumed: a negative step turns them round.)
  const std::ptrdiff_t bottom_row =
      (std::max(ty[0].first, ty[1].first) + 1) * static_cast<std::ptrdiff_t>(frame.step[0]);
  const __m256 one = _mm256_set1_ps(1.0f);
  int i = 0;  // the cells before i are done
  while (i < width) {
    // The last group ends at the row's end, overlapping the one before (its
    // cells come out the same twice).
    const int at = std::min(i, width - 8);
    const int farthest = std::max({offset[0][at], offset[1][at], offset[0][at + 7], offset[1][at + 7]});
    if (bottom_row + farthest + Channels > last_read) break;  // the rest cell by cell
    __m256 total = _mm256_setzero_ps();
    for (int qy = 0; qy < 2; ++qy) {
      const uchar* r0 = frame.ptr<uchar>(ty[qy].first);
      const uchar* r1 = frame.ptr<uchar>(ty[qy].first + 1);
      const __m256 ay = _mm256_set1_ps(ty[qy].weight);
      for (int qx = 0; qx < 2; ++qx) {
        const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(offset[qx] + at));
        const __m256 ax = _mm256_loadu_ps(weight[qx] + at), rest_x = _mm256_sub_ps(one, ax);
        __m256i p00, p01, p10, p11;
        gather_pairs<Channels>(r0, x, p00, p01);
        gather_pairs<Channels>(r1, x, p10, p11);
        const __m256 top = _mm256_add_ps(_mm256_mul_ps(rest_x, lanes_gray<Channels>(p00)),
                                         _mm256_mul_ps(ax, lanes_gray<Channels>(p01)));
        const __m256 bottom = _mm256_add_ps(_mm256_mul_ps(rest_x, lanes_gray<Channels>(p10)),
                                            _mm256_mul_ps(ax, lanes_gray<Channels>(p11)));
        total =
            _mm256_add_ps(total, _mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(one, ay), top), _mm256_mul_ps(ay, bottom)));
      }
    }
    _mm256_storeu_ps(out + at, _mm256_mul_ps(total, _mm256_set1_ps(0.25f)));
    i = at + 8;
  }
  for (; i < width; ++i) out[i] = cell_mean<Channels>(frame, cols + 2 * i, ty);
}
#endif

#if defined(__x86_64__)
// Sixteen cells a step without gathers (AVX-512 VBMI): a sample's grid is
// separable, so every row's taps lie in the same columns, and each sixteen
// cells' taps in one, two or four windows of 128 bytes of a source row (one
// per sixteen, eight or four cells: a BGR frame's at steps up to 2.5, 5.3 and
// 11.6 source pixels, a monochrome one's up to 8, 16 and 36). A byte
// permutation made once per sample picks their pixels out of each window,
// where the eight-cell path gathers each pixel. (Eight windows, of two cells
// each, cost more than the gathers.)
constexpr int kMostWindows = 4;
struct CellGroup {
  int first;                             // the group's first cell (the last group ends at the row's end, overlapping)
  int windows;                           // 1, 2, 4 or 8, each for as many successive lanes
  std::array<int, kMostWindows> window;  // each window's first byte in a row
  alignas(64) uint8_t index[2][2][64];   // [quarter tap][its pixel, the next] lane i's first bytes: B, G, R (or value)
  alignas(64) float weight[2][16];       // [quarter tap] lane i's weight of the next pixel
};

// The groups of a row of `width` cells whose quarter taps are `cols`, or
// false where `width` is under sixteen or two cells' taps span more than a window.
template <int Channels>
bool cell_groups(const Tap* cols, int width, std::vector<CellGroup>& out) {
  if (width < 16) return false;
  out.resize(static_cast<std::size_t>((width + 15) / 16));
  constexpr int kRead = Channels < 3 ? Channels : 3;  // the bytes of a pixel its gray is made of
  for (std::size_t g = 0; g < out.size(); ++g) {
    CellGroup& group = out[g];
    group.first = std::min(16 * static_cast<int>(g), width - 16);
    const Tap* taps = cols + 2 * group.first;
    // The fewest windows that hold their lanes' bytes (found, not assumed: a
    // negative step reads its taps from right to left).
    for (group.windows = 1;; group.windows *= 2) {
      if (group.windows > kMostWindows) return false;
      const int lanes = 16 / group.windows;
      bool fits = true;
      for (int w = 0; w < group.windows; ++w) {
        int lowest = std::numeric_limits<int>::max(), highest = -1;
        for (int i = w * lanes; i < (w + 1) * lanes; ++i)
          for (int q = 0; q < 2; ++q) {
            lowest = std::min(lowest, Channels * taps[2 * i + q].first);
            highest = std::max(highest, Channels * (taps[2 * i + q].first + 1) + kRead - 1);
          }
        fits = fits && highest - lowest < 128;
        group.window[static_cast<std::size_t>(w)] = lowest;
      }
      if (fits) break;
    }
    for (int i = 0; i < 16; ++i)
      for (int q = 0; q < 2; ++q) {
        group.weight[q][i] = taps[2 * i + q].weight;
        const int from = group.window[static_cast<std::size_t>(i / (16 / group.windows))];
        for (int next = 0; next < 2; ++next)
          for (int k = 0; k < 4; ++k)  // (the bytes past a pixel's B, G, R are never read)
            group.index[q][next][4 * i + k] =
                static_cast<uint8_t>(k < kRead ? Channels * (taps[2 * i + q].first + next) + k - from : 0);
      }
  }
  return true;
}

// lanes_gray, sixteen lanes wide.
template <int Channels>
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline __m512 lanes_gray16(__m512i bytes) {
  const __m512i low = _mm512_set1_epi32(0xFF);
  if constexpr (Channels == 1) {
    return _mm512_cvtepi32_ps(_mm512_and_si512(bytes, low));
  } else {
    const __m512 b = _mm512_cvtepi32_ps(_mm512_and_si512(bytes, low));
    const __m512 g = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(bytes, 8), low));
    const __m512 r = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(bytes, 16), low));
    return _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(0.114f), b), _mm512_mul_ps(_mm512_set1_ps(0.587f), g)),
        _mm512_mul_ps(_mm512_set1_ps(0.299f), r));
  }
}

// A group's two quarter taps along source row `row`: each the gray of its
// pixel and the next, weighed as cell_mean weighs them.
template <int Channels, int Windows>
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline void across_row(const cv::Mat& frame, const uchar* row,
                                                                          const CellGroup& group, __m512 across[2]) {
  __m512i pixel[2][2];
  constexpr int lanes = 16 / Windows;
  for (int w = 0; w < Windows; ++w) {
    __m512i a0, a1;
    window_of(frame, row + group.window[static_cast<std::size_t>(w)], a0, a1);
    const auto mine = static_cast<__mmask16>(((1u << lanes) - 1) << (w * lanes));
    for (int q = 0; q < 2; ++q)
      for (int next = 0; next < 2; ++next) {
        const __m512i taken = _mm512_permutex2var_epi8(a0, _mm512_load_si512(group.index[q][next]), a1);
        pixel[q][next] = w == 0 ? taken : _mm512_mask_blend_epi32(mine, pixel[q][next], taken);
      }
  }
  const __m512 one = _mm512_set1_ps(1.0f);
  for (int q = 0; q < 2; ++q) {
    const __m512 ax = _mm512_load_ps(group.weight[q]);
    across[q] = _mm512_add_ps(_mm512_mul_ps(_mm512_sub_ps(one, ax), lanes_gray16<Channels>(pixel[q][0])),
                              _mm512_mul_ps(ax, lanes_gray16<Channels>(pixel[q][1])));
  }
}

// A row of cells, sixteen a step: cell_row_avx2's arithmetic (and so
// cell_mean's, bit for bit), its reads permuted out of rows.
template <int Channels, int Windows>
SACCADE_AVX512_VBMI __attribute__((always_inline)) inline void cell_group_avx512(const cv::Mat& frame,
                                                                                 const CellGroup& group, const Tap* ty,
                                                                                 float* out) {
  const __m512 one = _mm512_set1_ps(1.0f);
  __m512 total = _mm512_setzero_ps(), top[2], bottom[2];
  for (int qy = 0; qy < 2; ++qy) {
    // (Where the lower quarter point's first row is the upper one's second, as at most steps, it is read once.)
    if (qy == 1 && ty[1].first == ty[0].first + 1)
      top[0] = bottom[0], top[1] = bottom[1];
    else
      across_row<Channels, Windows>(frame, frame.ptr<uchar>(ty[qy].first), group, top);
    across_row<Channels, Windows>(frame, frame.ptr<uchar>(ty[qy].first + 1), group, bottom);
    const __m512 ay = _mm512_set1_ps(ty[qy].weight), rest_y = _mm512_sub_ps(one, ay);
    for (int qx = 0; qx < 2; ++qx)
      total = _mm512_add_ps(total, _mm512_add_ps(_mm512_mul_ps(rest_y, top[qx]), _mm512_mul_ps(ay, bottom[qx])));
  }
  _mm512_storeu_ps(out + group.first, _mm512_mul_ps(total, _mm512_set1_ps(0.25f)));
}

template <int Channels>
SACCADE_AVX512_VBMI void cell_row_avx512(const cv::Mat& frame, const std::vector<CellGroup>& groups, const Tap* ty,
                                         float* out) {
  for (const CellGroup& group : groups) switch (group.windows) {
      case 1: cell_group_avx512<Channels, 1>(frame, group, ty, out); break;
      case 2: cell_group_avx512<Channels, 2>(frame, group, ty, out); break;
      default: cell_group_avx512<Channels, 4>(frame, group, ty, out); break;
    }
}
#endif

// The mean gray of each cell from four bilinear samples at its quarter
// points: a retina level's pixel, for any step and any sub-pixel position,
// read straight from the frame. Taps are per column and per row (the grid is
// separable), so each sample costs its four pixels' reads and nothing else;
// with AVX2, eight cells at a time, bit for bit the same.
template <int Channels>
void sample_cells(const cv::Mat& frame, const Tap* cols, const Tap* rows, cv::Size size, float* out,
                  [[maybe_unused]] bool vectorised) {
#if defined(__x86_64__)
  thread_local std::vector<CellGroup> groups;  // grows to the widest sample, then allocates no more
  if (vectorised && avx512vbmi_usable() && cell_groups<Channels>(cols, size.width, groups)) {
    for (int j = 0; j < size.height; ++j) cell_row_avx512<Channels>(frame, groups, rows + 2 * j, out + j * size.width);
    return;
  }
  if (size.width >= 8 && offsets_fit_lanes(frame) && vectorised && avx2_here()) {
    thread_local std::vector<int> offsets;  // grow to the widest sample, then allocate no more
    thread_local std::vector<float> weights;
    offsets.resize(2 * static_cast<std::size_t>(size.width));
    weights.resize(2 * static_cast<std::size_t>(size.width));
    const int* offset[2] = {offsets.data(), offsets.data() + size.width};
    const float* weight[2] = {weights.data(), weights.data() + size.width};
    for (int i = 0; i < size.width; ++i)
      for (int q = 0; q < 2; ++q) {
        offsets[static_cast<std::size_t>(q * size.width + i)] = cols[2 * i + q].first * Channels;
        weights[static_cast<std::size_t>(q * size.width + i)] = cols[2 * i + q].weight;
      }
    for (int j = 0; j < size.height; ++j)
      cell_row_avx2<Channels>(frame, cols, offset, weight, rows + 2 * j, size.width, out + j * size.width);
    return;
  }
#endif
  for (int j = 0; j < size.height; ++j)
    for (int i = 0; i < size.width; ++i)
      out[j * size.width + i] = cell_mean<Channels>(frame, cols + 2 * i, rows + 2 * j);
}

// Whether the one pass gives what OpenCV's calls give for this frame and map:
// OpenCV 4.6 to 4.10's arithmetic (4.11 rewrote warpAffine), source
// positions that fit its 16-bit pixel coordinates and the pass's 32-bit
// fixed point, byte offsets that fit 32 bits.
bool one_pass_for(const cv::Mat& frame, const cv::Matx23d& m, cv::Size size) {
  if (!warp_to_gray_in_one_pass() || (frame.type() != CV_8UC3 && frame.type() != CV_8UC1)) return false;
  constexpr int kLargest = 32767;  // OpenCV's pixel coordinates are 16-bit
  if (frame.cols > kLargest || frame.rows > kLargest || !offsets_fit_lanes(frame)) return false;
  for (const cv::Point2d corner : {cv::Point2d(0, 0), cv::Point2d(size.width, 0), cv::Point2d(0, size.height),
                                   cv::Point2d(size.width, size.height)}) {
    const double x = m(0, 0) * corner.x + m(0, 1) * corner.y + m(0, 2);
    const double y = m(1, 0) * corner.x + m(1, 1) * corner.y + m(1, 2);
    if (!(std::abs(x) < kLargest && std::abs(y) < kLargest)) return false;  // (also NaN)
  }
  return true;
}

// warp_to_gray's rows of an 8-bit frame of `Channels` channels (1 or 3):
// sixteen pixels a step where AVX-512 VBMI is usable (from windows of the
// source rows where the map is upright and they hold its taps, else
// gathered), else eight.
template <int Channels, class RowStart>
void warp_rows(const cv::Mat& frame, const cv::Matx23d& m, cv::Size size, const int* x_step, const int* y_step,
               const RowStart& row_start, cv::Mat& out) {
  auto* row = warp_row_avx2<Channels>;
#if defined(__x86_64__)
  thread_local std::vector<UprightGroup> groups;  // grows to the widest output, then allocates no more
  if (m(0, 1) == 0 && m(1, 0) == 0 && avx512vbmi_usable() &&
      upright_groups<Channels>(frame, x_step, row_start(0, 0), size.width, groups)) {
    for (int y = 0; y < size.height; ++y) {
      const int fixed = row_start(1, y) >> (10 - kSubpixelBits);
      const int sy = fixed >> kSubpixelBits;
      upright_row_avx512<Channels>(frame, groups, frame.ptr<uchar>(std::clamp(sy, 0, frame.rows - 1)),
                                   frame.ptr<uchar>(std::clamp(sy + 1, 0, frame.rows - 1)), fixed & (kSubpixels - 1),
                                   out.ptr<uchar>(y));
    }
    return;
  }
  if (avx512vbmi_usable()) row = gathered_row_avx512<Channels>;
#endif
  for (int y = 0; y < size.height; ++y)
    row(frame, x_step, y_step, row_start(0, y), row_start(1, y), size.width, out.ptr<uchar>(y));
}

}  // namespace

bool frame_samples_vectorised() { return avx2_here(); }

bool warp_to_gray_sixteen_pixels_a_step() {
#if defined(__x86_64__)
  return warp_to_gray_in_one_pass() && avx512vbmi_usable();
#else
  return false;
#endif
}

bool warp_to_gray_in_one_pass() {
#if CV_VERSION_MAJOR == 4 && CV_VERSION_MINOR >= 6 && CV_VERSION_MINOR <= 10
  return avx2_here();
#else
  return false;
#endif
}

void warp_to_gray(const cv::Mat& frame, const cv::Matx23d& inverse_map, cv::Size size, cv::Mat& out, cv::Mat& scratch) {
  if (!one_pass_for(frame, inverse_map, size)) {
    cv::warpAffine(frame, scratch, inverse_map, size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
    if (scratch.channels() == 1)
      scratch.copyTo(out);
    else
      cv::cvtColor(scratch, out, scratch.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    return;
  }
  out.create(size, CV_8U);
  thread_local std::vector<int> steps;  // grows to the widest output, then allocates no more
  steps.resize(2 * static_cast<std::size_t>(size.width));
  int* x_step = steps.data();
  int* y_step = steps.data() + size.width;
  const cv::Matx23d& m = inverse_map;
  for (int x = 0; x < size.width; ++x) {
    x_step[x] = cv::saturate_cast<int>(m(0, 0) * x * kMapScale);
    y_step[x] = cv::saturate_cast<int>(m(1, 0) * x * kMapScale);
  }
  // Output row y's first source position along axis 0 (x) or 1 (y), in 1/1024 pixel.
  const auto row_start = [&m](int axis, int y) {
    constexpr int kHalf = kMapScale / kSubpixels / 2;
    return cv::saturate_cast<int>((m(axis, 1) * y + m(axis, 2)) * kMapScale) + kHalf;
  };
  if (frame.channels() == 1)
    warp_rows<1>(frame, m, size, x_step, y_step, row_start, out);
  else
    warp_rows<3>(frame, m, size, x_step, y_step, row_start, out);
}

void pyr_down(const cv::Mat& src, cv::Mat& dst) {
  CV_Assert(src.type() == CV_8UC1 && src.cols >= 4 && src.rows >= 4 && src.cols % 2 == 0 && src.rows % 2 == 0);
  const int w = src.cols / 2, h = src.rows / 2, last_y = src.rows - 1;
  dst.create(h, w, CV_8U);
  // Per output row, five source rows weighed 1 4 6 4 1 (sums up to 16 x 255:
  // 16 bits), then along that row the same, to 256 and rounded. OpenCV
  // filters along x first; the sums are integers, so the order changes
  // nothing, and this way the wide pass (every source column) is the one
  // that vectorises.
  thread_local std::vector<uint16_t> column;  // grows to the widest source, then allocates no more
  column.resize(static_cast<std::size_t>(src.cols) + 4);
  uint16_t* v = column.data() + 2;  // v[-2], v[-1], v[cols], v[cols + 1]: the row's reflected border
  const auto reflect = [](int i, int last) { return i < 0 ? -i : i > last ? 2 * last - i : i; };
  for (int y = 0; y < h; ++y) {
    const uchar* r[5];
    for (int k = 0; k < 5; ++k) r[k] = src.ptr<uchar>(reflect(2 * y + k - 2, last_y));
    for (int x = 0; x < src.cols; ++x)
      v[x] = static_cast<uint16_t>(r[0][x] + 4 * r[1][x] + 6 * r[2][x] + 4 * r[3][x] + r[4][x]);
    v[-2] = v[2], v[-1] = v[1], v[src.cols] = v[src.cols - 2], v[src.cols + 1] = v[src.cols - 3];
    uchar* d = dst.ptr<uchar>(y);
    for (int x = 0; x < w; ++x) {
      const uint16_t* c = v + 2 * x;
      d[x] = static_cast<uchar>((c[-2] + 4 * c[-1] + 6 * c[0] + 4 * c[1] + c[2] + 128) >> 8);
    }
  }
}

void sample_cell_means(const cv::Mat& frame, cv::Point2d center, double step_x, double step_y, cv::Size size,
                       float* out, bool vectorised) {
  if (frame.rows < 2 || frame.cols < 2) {  // no pixel pairs to interpolate between: the frame's first pixel's gray
    const float gray = frame.empty()           ? 0.0f
                       : frame.channels() == 1 ? pixel_gray<1>(frame.data)
                                               : pixel_gray<3>(frame.data);
    std::fill(out, out + size.area(), gray);
    return;
  }
  thread_local std::vector<Tap> taps;  // grows to the largest sample, then allocates no more
  taps.resize(2 * static_cast<std::size_t>(size.width + size.height));
  Tap* cols = taps.data();
  Tap* rows = taps.data() + 2 * size.width;
  quarter_taps(center.x, step_x, size.width, frame.cols, cols);
  quarter_taps(center.y, step_y, size.height, frame.rows, rows);
  switch (frame.channels()) {
    case 1: return sample_cells<1>(frame, cols, rows, size, out, vectorised);
    case 3: return sample_cells<3>(frame, cols, rows, size, out, vectorised);
    default: return sample_cells<4>(frame, cols, rows, size, out, vectorised);
  }
}

}  // namespace saccade::fovea
