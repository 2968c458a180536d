// What the running CPU offers, for the code paths chosen at run time (AVX, AVX2, AVX-512 kernels
// beside their SSE or scalar references). Each answer is computed once. Outside x86-64 GCC/Clang the
// answers are false, so callers fall back to their reference paths.
//
// The environment variable PANOSCAN_CPU caps what the dispatch may use (`avx512`, `avx2`, `avx`,
// `sse2`; unset or `native`: all the CPU has). Every kernel is meant to give the same bits as its
// reference, so a capped run reproduces what a machine without the wider instructions computes, and
// comparing a capped run with an uncapped one checks that claim for a whole pipeline
// (tests/isa_identity_test.cpp). Embree chooses its own kernels by the CPU; PANOSCAN_EMBREE_ISA caps them.
#pragma once

#include <string>

namespace panoscan::cpu {

enum class Isa { kSse2 = 0, kAvx = 1, kAvx2 = 2, kAvx512 = 3 };

// The cap from PANOSCAN_CPU, read once; an unknown value throws Error naming the variable.
Isa isa_cap();
// "sse2", "avx", "avx2", "avx512".
const char* isa_name(Isa isa);
// The widest of the four the CPU offers, below the cap: what the dispatch below uses.
Isa dispatched_isa();
// rtcNewDevice's configuration string: "" unless the environment variable PANOSCAN_EMBREE_ISA caps
// Embree's kernels (`avx512`, `avx2`, `avx`, `sse4.2`, `sse2`): then "max_isa=<it>". An unknown value
// throws Error naming the variable (Embree itself would ignore it).
std::string embree_device_config();
// The kernels Embree 3 runs on this CPU ("avx512", "avx2", "avx", "sse4.2", "sse2"): the widest whose
// features the CPU has, as Embree chooses (AVX-512 F/CD/DQ/BW/VL; AVX2 with FMA, BMI1 and BMI2), under
// PANOSCAN_EMBREE_ISA. Their hits differ at a few silhouette pixels, so a scan's provenance and the
// tables' scan cache name them.
const char* ray_tracer_isa();

#if defined(__x86_64__) && defined(__GNUC__)
inline bool has_avx() {
  static const bool has = __builtin_cpu_supports("avx") && isa_cap() >= Isa::kAvx;
  return has;
}
inline bool has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2") && isa_cap() >= Isa::kAvx2;
  return has;
}
// AVX-512 F and DQ (64-bit integer conversions to double).
inline bool has_avx512dq() {
  static const bool has =
      __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && isa_cap() >= Isa::kAvx512;
  return has;
}
// BMI2 (pdep, pext): every AVX-512 CPU so far has it, but it is a separate flag. Capped with AVX2,
// which came with it (Haswell).
inline bool has_bmi2() {
  static const bool has = __builtin_cpu_supports("bmi2") && isa_cap() >= Isa::kAvx2;
  return has;
}
#else
inline bool has_avx() { return false; }
inline bool has_avx2() { return false; }
inline bool has_avx512dq() { return false; }
inline bool has_bmi2() { return false; }
#endif

}  // namespace panoscan::cpu
