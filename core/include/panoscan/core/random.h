// Seeded random streams whose draws depend only on their key, never on thread count or on the
// order in which work is scheduled: every stream is keyed by (seed, camera, frame, purpose, lane)
// and generates with xoshiro256**. Normal deviates use our own ziggurat (Marsaglia & Tsang), so
// results are identical across standard libraries and cheap enough for per-pixel noise.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace panoscan {

enum class RandomPurpose : std::uint32_t {
  kMotion = 1,
  kWobble = 2,
  kShutter = 3,
  kExtrinsicsError = 4,
  kDepthShift = 5,
  kDepthDisparity = 6,
  kDepthLateral = 7,
  kDropout = 8,
  kSpeckle = 9,
  kColour = 10,
  kScene = 11,
  kGeneric = 100,
};

// Mixes a 64-bit value (SplitMix64 finaliser).
std::uint64_t mix64(std::uint64_t value);

namespace detail {
// Ziggurat tables for the standard normal (Marsaglia & Tsang 2000, 128 layers of equal area v):
// layer i is a rectangle [0, width[i]] x [f(width[i]), f(width[i+1])] with f(x) = exp(-x^2/2);
// layer 0 is the base strip plus the tail beyond r.
struct ZigguratTables {
  static constexpr int kLayers = 128;
  static constexpr double kTailStart = 3.442619855899;       // r
  static constexpr double kLayerArea = 9.91256303526217e-3;  // v
  double width[kLayers + 1];
  double height[kLayers + 1];  // f(width)
  ZigguratTables();
};
const ZigguratTables& ziggurat_tables();
}  // namespace detail

class RandomStream;

// `n` normal deviates from each of `count` streams, times `scale`: out[s][i] = streams[s].normal() *
// scale for i = 0 .. n - 1, each stream advanced as those calls advance it. Where the CPU has
// AVX-512, eight streams draw at once in its lanes (the simulator's per-pixel noise draws three
// deviates per pixel, one stream per row): the same values bit for bit, whatever `count`.
void draw_normals(RandomStream* streams, std::size_t count, std::size_t n, double scale, double* const* out);

class RandomStream {
 public:
  RandomStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
               std::int64_t lane = 0);

  // next_u64 and the common path of normal are inline: the simulator's noise draws three normal
  // deviates per pixel, and the calls were a third of their cost.
  std::uint64_t next_u64() {
    // xoshiro256** (Blackman & Vigna).
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }
  double uniform();                      // [0, 1)
  double uniform(double lo, double hi);  // [lo, hi)
  // N(0, 1). Ziggurat: one 64-bit draw and a comparison for ~99% of samples; exact in distribution.
  double normal() {
    const std::uint64_t bits = next_u64();
    const int layer = static_cast<int>(bits & 127u);
    const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;
    const double x = u * ziggurat_->width[layer];
    if (x < ziggurat_->width[layer + 1]) {  // inside the rectangle's core
      // The sign from bit 7 without a branch: a branch on it is mispredicted half the time, and
      // those were the largest single cost of the simulator's per-pixel noise. Flipping the IEEE
      // sign bit is exactly -x.
      std::uint64_t x_bits;
      std::memcpy(&x_bits, &x, sizeof x_bits);
      x_bits ^= (bits & 128u) << 56;
      double signed_x;
      std::memcpy(&signed_x, &x_bits, sizeof signed_x);
      return signed_x;
    }
    return normal_outside_core(bits);
  }
  double normal(double mean, double stddev) { return mean + stddev * normal(); }
  int uniform_int(int lo, int hi_inclusive);

 private:
  friend void draw_normals(RandomStream*, std::size_t, std::size_t, double, double* const*);
  friend void draw_normals_lanes(RandomStream*, std::size_t, double, double* const*, std::size_t*);
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  // The rest of normal() for a draw `bits` outside its layer's core: the tail or the wedge, and
  // further draws while they are rejected.
  double normal_outside_core(std::uint64_t bits);
  // draw_normals' per-stream step: the normal() values of this stream's next `count` draws, already
  // made (`bits`; `scaled_core`, each one's value times `scale` if it falls inside its layer's core;
  // `outside`, bit i set where draw i does not), written to `out`. A draw outside its core goes
  // through normal_outside_core, which takes its further draws from those that follow it, then from
  // the stream (left just past the `count` draws). Returns how many values it wrote.
  std::size_t normals_from_draws(const std::uint64_t* bits, const double* scaled_core, const std::uint64_t* outside,
                                 std::size_t count, double scale, double* out);

  std::uint64_t state_[4];
  const detail::ZigguratTables* ziggurat_;
};

}  // namespace panoscan
