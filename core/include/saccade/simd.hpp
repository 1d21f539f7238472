#pragma once
// Marks a hot function to be compiled twice, for AVX2 and for the baseline,
// the right one chosen at load time on the CPU at hand. Not under
// ThreadSanitizer, whose runtime is not up yet when the ifunc resolver of a
// clone runs at load time.
#if defined(__SANITIZE_THREAD__) || !defined(__x86_64__)
#define SACCADE_AVX2_CLONE
#else
#define SACCADE_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#endif
