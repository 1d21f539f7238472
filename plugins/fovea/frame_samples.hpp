#pragma once
// The box tracker's reads of the frame, the largest part of its time: a
// look's patch (warped along an affine map, then gray) and cell means (the
// scale filter's samples, the whole-frame search's coarse view). With AVX2
// both take eight pixels at a time, with AVX-512 VBMI sixteen, bit for bit
// what the plain code and OpenCV give, so the tracker's every figure stays
// the same (docs/tracking.md, Time). Allocation-free in steady state.
#include <opencv2/core.hpp>

namespace saccade::fovea {

// A look's patch: bit for bit what
//   cv::warpAffine(frame, fine, inverse_map, size, INTER_LINEAR | WARP_INVERSE_MAP, BORDER_REPLICATE);
//   cv::cvtColor(fine, out, COLOR_BGR2GRAY);
// give (OpenCV's 5-bit fixed-point bilinear and 15-bit gray; for a
// monochrome frame the warp alone), in one pass for an 8-bit BGR or
// monochrome frame on a CPU with AVX2 (and a map whose source positions stay
// within 32767 pixels), allocating nothing; otherwise those calls, with the
// warped patch in `scratch` (OpenCV's warpAffine allocates its own buffers on
// every call). `frame` 8-bit with 1, 3 or 4 channels;
// `inverse_map` takes an output pixel to the frame's. With AVX-512 VBMI the
// taps of sixteen output pixels at a time are picked out of 128-byte windows
// of the source rows by byte permutations instead of gathered one by one, the
// same arithmetic: an upright map (no turn; a width a multiple of sixteen, a
// step up to 5.7 source pixels of a BGR frame, 18 of a monochrome one) reads
// every row's taps from the same columns, its permutations made once per call
// (about five times faster); a map turned a little (a step up to 2.6, or 8,
// up to six source rows under sixteen pixels: the turn search's 5 degrees)
// makes them per row (about 1.6 times faster).
void warp_to_gray(const cv::Mat& frame, const cv::Matx23d& inverse_map, cv::Size size, cv::Mat& out, cv::Mat& scratch);

// A size.width x size.height gray sample centred on `center` (source pixels),
// `step_x` x `step_y` source pixels a cell, one cell mean per pixel, row by
// row into `out`: the mean of four bilinear samples at the cell's quarter
// points, a retina level's pixel for any step and sub-pixel position, read
// straight from an 8-bit frame of 1, 3 or 4 channels (the frame's border
// replicated; a frame under 2x2 gives its first pixel's gray everywhere).
// `vectorised` false asks for the plain loop, which the vectorised one
// matches bit for bit (tests compare them): eight cells at a time with AVX2,
// their pixels gathered; with AVX-512 VBMI, at widths of sixteen cells and
// more, sixteen, their pixels picked out of one, two or four 128-byte windows
// of each source row by byte permutations made once per call (steps up to
// 11.6 source pixels of a BGR frame, 36 of a monochrome one; two to four
// times faster than the gathers on a BGR frame, four to eight on a monochrome one).
void sample_cell_means(const cv::Mat& frame, cv::Point2d center, double step_x, double step_y, cv::Size size,
                       float* out, bool vectorised = true);

// cv::pyrDown(src, dst, src.size() / 2) for an 8-bit single-channel `src` of
// even width and height (at least 4x4): the same 5x5 binomial weights, the
// border reflected without repeating its pixel (BORDER_REFLECT_101) and the
// same rounding, so bit for bit the same. OpenCV's allocates a buffer on every
// call; this one only when `src` is wider or taller than any before.
void pyr_down(const cv::Mat& src, cv::Mat& dst);

// Whether this CPU takes the vectorised paths of sample_cell_means (AVX2; the
// sixteen-cell one also needs what warp_to_gray_sixteen_pixels_a_step says).
bool frame_samples_vectorised();

// Whether warp_to_gray takes its one pass for an 8-bit BGR frame (AVX2, and
// the OpenCV whose arithmetic it repeats: 4.6 to 4.10).
bool warp_to_gray_in_one_pass();

// Whether warp_to_gray takes upright and slightly turned maps sixteen pixels a
// step (the CPU has AVX-512 VBMI, and SACCADE_AVX512 is not 0).
bool warp_to_gray_sixteen_pixels_a_step();

}  // namespace saccade::fovea
