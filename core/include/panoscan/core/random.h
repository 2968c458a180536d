// Seeded random streams whose draws depend only on their key, never on thread count or on the
// order in which work is scheduled: every stream is keyed by (seed, camera, frame, purpose, lane)
// and generates with xoshiro256**. Normal deviates use our own ziggurat (Marsaglia & Tsang), so
// results are identical across standard libraries and cheap enough for per-pixel noise.
#pragma once

#include <cstdint>

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

class RandomStream {
 public:
  RandomStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
               std::int64_t lane = 0);

  std::uint64_t next_u64();
  double uniform();                      // [0, 1)
  double uniform(double lo, double hi);  // [lo, hi)
  double normal();                       // N(0, 1)
  double normal(double mean, double stddev) { return mean + stddev * normal(); }
  int uniform_int(int lo, int hi_inclusive);

 private:
  std::uint64_t state_[4];
};

}  // namespace panoscan
