#include "panoscan/core/random.h"

#include <cmath>

namespace panoscan {

std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

RandomStream::RandomStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                           std::int64_t lane)
    : ziggurat_(&detail::ziggurat_tables()) {
  // Chain the key parts through the mixer so that nearby keys give unrelated states.
  std::uint64_t h = mix64(seed);
  h = mix64(h ^ static_cast<std::uint64_t>(camera + 0x1234));
  h = mix64(h ^ static_cast<std::uint64_t>(frame + 0x5678));
  h = mix64(h ^ static_cast<std::uint64_t>(purpose));
  h = mix64(h ^ static_cast<std::uint64_t>(lane + 0x9ABC));
  for (auto& s : state_) {
    h = mix64(h);
    s = h;
  }
}

double RandomStream::uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

double RandomStream::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

int RandomStream::uniform_int(int lo, int hi_inclusive) {
  const std::uint64_t span = static_cast<std::uint64_t>(hi_inclusive - lo) + 1;
  return lo + static_cast<int>(next_u64() % span);
}

namespace detail {

ZigguratTables::ZigguratTables() {
  auto f = [](double x) { return std::exp(-0.5 * x * x); };
  width[0] = kLayerArea / f(kTailStart);
  width[1] = kTailStart;
  for (int i = 2; i < kLayers; ++i) width[i] = std::sqrt(-2.0 * std::log(kLayerArea / width[i - 1] + f(width[i - 1])));
  width[kLayers] = 0.0;
  for (int i = 0; i <= kLayers; ++i) height[i] = f(width[i]);
}

const ZigguratTables& ziggurat_tables() {
  static const ZigguratTables tables;
  return tables;
}

}  // namespace detail

double RandomStream::normal_outside_core(std::uint64_t bits) {
  const detail::ZigguratTables& z = *ziggurat_;
  for (;;) {
    const int layer = static_cast<int>(bits & 127u);
    const double sign = (bits & 128u) ? -1.0 : 1.0;
    const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;
    const double x = u * z.width[layer];
    if (x < z.width[layer + 1]) return sign * x;  // inside the rectangle's core (a redraw)
    if (layer == 0) {
      // Tail beyond r (Marsaglia 1964).
      double a, b;
      do {
        a = -std::log(1.0 - uniform()) / detail::ZigguratTables::kTailStart;
        b = -std::log(1.0 - uniform());
      } while (2.0 * b < a * a);
      return sign * (detail::ZigguratTables::kTailStart + a);
    }
    // Wedge between the rectangle and the curve.
    const double y = z.height[layer] + uniform() * (z.height[layer + 1] - z.height[layer]);
    if (y < std::exp(-0.5 * x * x)) return sign * x;
    bits = next_u64();
  }
}

}  // namespace panoscan
