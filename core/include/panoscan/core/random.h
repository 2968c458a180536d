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

// The bulk generator's ziggurat (BulkNormalStream): 256 layers of equal area v (Marsaglia & Tsang
// 2000's 256-layer constants), indexed by 8 bits of a 32-bit draw; `unit_width` is width / 2^23, the
// width of one step of its 23-bit u.
struct BulkZigguratTables {
  static constexpr int kLayers = 256;
  static constexpr double kTailStart = 3.6541528853610088;  // r
  static constexpr double kLayerArea = 4.92867323399e-3;    // v
  double unit_width[kLayers];
  double width[kLayers + 1];
  double height[kLayers + 1];  // f(width)
  BulkZigguratTables();
};
const BulkZigguratTables& bulk_ziggurat_tables();
}  // namespace detail

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
  friend class BulkNormalStream;
  // A stream whose state comes from an already mixed key.
  explicit RandomStream(std::uint64_t key);
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  // The rest of normal() for a draw `bits` outside its layer's core: the tail or the wedge, and
  // further draws while they are rejected.
  double normal_outside_core(std::uint64_t bits);
  std::uint64_t state_[4];
  const detail::ZigguratTables* ziggurat_;
};

// Normal deviates in bulk, for per-pixel noise (the simulator draws three per depth pixel): one
// keyed stream made of eight xoshiro256** generators side by side, so that each of them is a lane of
// an AVX-512 or AVX2 operation, and each 64-bit draw gives two 32-bit draws. A 32-bit draw is a
// deviate of the 256-layer ziggurat (8 bits pick the layer, 1 the sign, 23 are u): x = u * width /
// 2^23 in double, returned where x < the next layer's width (98.5% of draws). The other 1.5% (the
// wedge and the tail) take their further uniforms from a scalar stream of their own, in the order
// of their positions, and are filled in after the lanes, so the lanes never wait on them.
// Draw k of a fill comes from step k / 16 of the eight generators, generator (k % 16) / 2, its low
// 32 bits for even k and its high 32 bits for odd k. Every instruction set computes the same bits
// (the scalar code is the reference; the lanes use the same IEEE operations, no contraction).
// Keyed like RandomStream; the sequence differs from RandomStream::normal's.
class BulkNormalStream {
 public:
  BulkNormalStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                   std::int64_t lane = 0);
  // The instruction set of the lanes: the widest the CPU has (and PANOSCAN_CPU allows), at most
  // AVX2, or the scalar reference. Each gives the same bits; a kernel the CPU lacks falls back to
  // the next narrower one.
  enum class Kernel { kFastest, kAvx2, kScalar };
  // The next `n` deviates times `scale` into out[0 .. n - 1]. A fill uses whole steps of the eight
  // generators (16 draws): a further fill starts at the next step, whatever this one left unused.
  void fill(std::size_t n, double scale, double* out, Kernel kernel = Kernel::kFastest);

  // How the last fill's draws went: how many left their layer's core (wedge or tail).
  std::size_t last_fill_outside_core() const { return last_fill_outside_core_; }

 private:
  // The deviate of a 32-bit draw outside its layer's core: the wedge test or the tail, with further
  // uniforms (and a whole further deviate where the wedge rejects) from rare_.
  double outside_core(std::uint32_t draw);
  void fill_scalar(std::size_t n, double scale, double* out);
  void fill_avx512(std::size_t n, double scale, double* out);
  void fill_avx2(std::size_t n, double scale, double* out);

  alignas(64) std::uint64_t state_[4][8];  // [word][generator]: a word of all eight is one vector
  RandomStream rare_;
  std::size_t last_fill_outside_core_ = 0;
};

}  // namespace panoscan
