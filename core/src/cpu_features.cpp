#include "panoscan/core/cpu_features.h"

#include <algorithm>
#include <cstdlib>
#include <iterator>

#include "panoscan/core/error.h"

namespace panoscan::cpu {

namespace {

Isa read_cap() {
  const char* value = std::getenv("PANOSCAN_CPU");
  if (value == nullptr) return Isa::kAvx512;
  const std::string name = value;
  if (name.empty() || name == "native" || name == "avx512") return Isa::kAvx512;
  if (name == "avx2") return Isa::kAvx2;
  if (name == "avx") return Isa::kAvx;
  if (name == "sse2") return Isa::kSse2;
  throw make_error("environment", "PANOSCAN_CPU", "'" + name + "' is not one of native, avx512, avx2, avx, sse2");
}

}  // namespace

Isa isa_cap() {
  static const Isa cap = read_cap();
  return cap;
}

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::kSse2: return "sse2";
    case Isa::kAvx: return "avx";
    case Isa::kAvx2: return "avx2";
    case Isa::kAvx512: return "avx512";
  }
  return "?";
}

Isa dispatched_isa() {
  if (has_avx512dq()) return Isa::kAvx512;
  if (has_avx2()) return Isa::kAvx2;
  if (has_avx()) return Isa::kAvx;
  return Isa::kSse2;
}

namespace {

// Embree 3's names for its kernel sets, narrowest first.
constexpr const char* kEmbreeIsas[] = {"sse2", "sse4.2", "avx", "avx2", "avx512"};
constexpr int kUncapped = -1;

// The index in kEmbreeIsas that PANOSCAN_EMBREE_ISA caps Embree at, or kUncapped (unset or "native").
// Embree ignores a name it does not know, so the name is checked here.
int embree_cap() {
  static const int cap = [] {
    const char* value = std::getenv("PANOSCAN_EMBREE_ISA");
    if (value == nullptr || *value == '\0' || std::string(value) == "native") return kUncapped;
    for (int k = 0; k < int(std::size(kEmbreeIsas)); ++k)
      if (std::string(value) == kEmbreeIsas[k]) return k;
    throw make_error("environment", "PANOSCAN_EMBREE_ISA",
                     "'" + std::string(value) + "' is not one of native, avx512, avx2, avx, sse4.2, sse2");
  }();
  return cap;
}

}  // namespace

std::string embree_device_config() {
  const int cap = embree_cap();
  return cap == kUncapped ? std::string() : std::string("max_isa=") + kEmbreeIsas[cap];
}

const char* ray_tracer_isa() {
  static const char* const isa = [] {
    int widest = 0;
#if defined(__x86_64__) && defined(__GNUC__)
    if (__builtin_cpu_supports("sse4.2")) widest = 1;
    if (widest == 1 && __builtin_cpu_supports("avx")) widest = 2;
    if (widest == 2 && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
        __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2"))
      widest = 3;
    if (widest == 3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl"))
      widest = 4;
#endif
    const int cap = embree_cap();
    return kEmbreeIsas[cap == kUncapped ? widest : std::min(widest, cap)];
  }();
  return isa;
}

}  // namespace panoscan::cpu
