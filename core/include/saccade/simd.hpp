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

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <string_view>

namespace saccade {

// SACCADE_AVX512=0 in the environment keeps every AVX-512 path on its AVX2
// code (to compare, or where AVX-512 lowers the clock).
inline bool avx512_wanted() {
  static const bool yes = [] {
    const char* value = std::getenv("SACCADE_AVX512");
    return value == nullptr || std::string_view(value) != "0";
  }();
  return yes;
}

// Whether AVX-512 (F) code may run: the CPU has it and SACCADE_AVX512 is not 0.
inline bool avx512f_usable() {
#if defined(__x86_64__)
  static const bool cpu = [] {
    __builtin_cpu_init();  // in case this runs before libgcc's constructor did (a plugin's static initialiser)
    return __builtin_cpu_supports("avx512f") != 0;
  }();
  return cpu && avx512_wanted();
#else
  return false;
#endif
}

// Whether AVX-512 code that permutes bytes (BW and VBMI) may run: the CPU
// has them and SACCADE_AVX512 is not 0.
inline bool avx512vbmi_usable() {
#if defined(__x86_64__)
  static const bool cpu = [] {
    __builtin_cpu_init();  // as above
    return __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vbmi");
  }();
  return cpu && avx512_wanted();
#else
  return false;
#endif
}

// A function compiled for AVX-512 that rounds as its AVX2 and baseline
// versions do: without fusing a multiply and an add into one rounding (which
// AVX-512 has and AVX2 alone has not), so its results are theirs to the bit.
#if defined(__x86_64__)
#define SACCADE_AVX512_EXACT __attribute__((target("avx512f"), optimize("fp-contract=off")))
#endif

// Sliding dot products with the placements as vector lanes: out[j], j < 8K, is
// the sum over rows y < rows and columns x < cols, in that order, of
// weight(y, x) * data[y * data_step + x + j]. K vectors of eight placements
// stay in registers over every weight (through memory, each product would
// wait on the store of the one before). Inlined into an AVX2 clone, a vector
// is one register (two SSE2 registers elsewhere). T: float, or int32_t for
// exact sums of whole numbers.
template <int K, class T, class Weight>
__attribute__((always_inline)) inline void sliding_dots(const T* __restrict data, std::ptrdiff_t data_step, int rows,
                                                        int cols, Weight weight, T* __restrict out) {
  typedef T Lanes __attribute__((vector_size(8 * sizeof(T))));
  Lanes acc[K];
  for (int k = 0; k < K; ++k) acc[k] = Lanes{};
  for (int y = 0; y < rows; ++y) {
    const T* row = data + y * data_step;
    for (int x = 0; x < cols; ++x) {
      const T w = weight(y, x);
      for (int k = 0; k < K; ++k) {
        Lanes v;
        std::memcpy(&v, row + x + 8 * k, sizeof v);
        acc[k] += w * v;
      }
    }
  }
  std::memcpy(out, acc, sizeof acc);
}

}  // namespace saccade
