// What the running CPU offers, for the code paths chosen at run time (AVX, AVX2, AVX-512 kernels
// beside their SSE or scalar references). Each answer is computed once. Outside x86-64 GCC/Clang the
// answers are false, so callers fall back to their reference paths.
#pragma once

namespace panoscan::cpu {

#if defined(__x86_64__) && defined(__GNUC__)
inline bool has_avx() {
  static const bool has = __builtin_cpu_supports("avx");
  return has;
}
inline bool has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
// AVX-512 F and DQ (64-bit integer conversions to double).
inline bool has_avx512dq() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
  return has;
}
// BMI2 (pdep, pext): every AVX-512 CPU so far has it, but it is a separate flag.
inline bool has_bmi2() {
  static const bool has = __builtin_cpu_supports("bmi2");
  return has;
}
#else
inline bool has_avx() { return false; }
inline bool has_avx2() { return false; }
inline bool has_avx512dq() { return false; }
inline bool has_bmi2() { return false; }
#endif

}  // namespace panoscan::cpu
