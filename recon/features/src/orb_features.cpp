// ORB detection and matching; see orb_features.h for the behaviour.
#include "panoscan/recon/orb_features.h"

#include <cstring>
#include <numeric>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace panoscan {

void detect_orb(const ImageU8& image, const OrbDetectorOptions& options, std::vector<OrbKeypoint>* keypoints,
                std::vector<OrbDescriptor>* descriptors) {
  keypoints->clear();
  descriptors->clear();
  if (image.empty()) return;
  cv::Mat grey;
  if (image.channels == 3) {
    const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.data.data()));
    cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  } else {
    grey = cv::Mat(image.height, image.width, CV_8UC1, const_cast<std::uint8_t*>(image.data.data()));
  }
  const int border = options.border_px > 0 ? options.border_px : options.patch_px;
  auto orb = cv::ORB::create(options.features, float(options.scale_factor), options.levels, border, 0, 2,
                             cv::ORB::HARRIS_SCORE, options.patch_px, options.fast_threshold);
  std::vector<cv::KeyPoint> cv_keypoints;
  cv::Mat cv_descriptors;
  orb->detectAndCompute(grey, cv::noArray(), cv_keypoints, cv_descriptors);
  keypoints->reserve(cv_keypoints.size());
  descriptors->reserve(cv_keypoints.size());
  for (std::size_t i = 0; i < cv_keypoints.size(); ++i) {
    keypoints->push_back({cv_keypoints[i].pt.x, cv_keypoints[i].pt.y, cv_keypoints[i].octave});
    OrbDescriptor d;
    std::memcpy(d.data(), cv_descriptors.ptr<std::uint8_t>(int(i)), 32);
    descriptors->push_back(d);
  }
}

namespace {

// Inlined into match_orb, which is compiled twice on x86-64 (below).
inline int hamming(const OrbDescriptor& a, const OrbDescriptor& b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a.data() + i, 8);
    std::memcpy(&y, b.data() + i, 8);
    distance += __builtin_popcountll(x ^ y);
  }
  return distance;
}

// The rule every matcher applies (orb_features.h): a's nearest candidate under the distance limit
// and the ratio test, then each b keeps the closest of the a's that chose it (the first on a tie).
// Slots are positions in the caller's lists of a and b.
class OneAPerB {
 public:
  explicit OneAPerB(std::size_t b_slots) : best_a_of_b_(b_slots, -1), best_distance_of_b_(b_slots, 1 << 20) {}

  void offer(int a_slot, int b_slot, int d1, int d2, const OrbMatchOptions& options) {
    if (b_slot < 0 || d1 > options.max_hamming || !(d1 < options.ratio * d2)) return;
    candidates_.push_back({a_slot, b_slot});
    if (d1 < best_distance_of_b_[std::size_t(b_slot)]) {
      best_distance_of_b_[std::size_t(b_slot)] = d1;
      best_a_of_b_[std::size_t(b_slot)] = a_slot;
    }
  }
  // (a slot, b slot) in the order offered.
  std::vector<std::pair<int, int>> resolve() const {
    std::vector<std::pair<int, int>> kept;
    for (const auto& [i, j] : candidates_)
      if (best_a_of_b_[std::size_t(j)] == i) kept.push_back({i, j});
    return kept;
  }

 private:
  std::vector<int> best_a_of_b_, best_distance_of_b_;
  std::vector<std::pair<int, int>> candidates_;
};

}  // namespace

int hamming_distance(const OrbDescriptor& a, const OrbDescriptor& b) { return hamming(a, b); }

// Debian builds for the x86-64 baseline, which has no POPCNT instruction: __builtin_popcountll
// becomes a libgcc call that took 7% of a tracking run. A clone for CPUs with POPCNT is picked at
// load time (GCC function multi-versioning); other CPUs run the baseline clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PANOSCAN_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define PANOSCAN_POPCNT_CLONES
#endif

PANOSCAN_POPCNT_CLONES std::vector<std::pair<int, int>>
match_orb(const std::vector<OrbDescriptor>& a, const std::vector<int>& subset_a, const std::vector<OrbDescriptor>& b,
          const std::vector<int>& subset_b, const OrbMatchOptions& options) {
  OneAPerB rule(subset_b.size());
  for (std::size_t i = 0; i < subset_a.size(); ++i) {
    const OrbDescriptor& da = a[std::size_t(subset_a[i])];
    int best = -1, d1 = 1 << 20, d2 = 1 << 20;
    for (std::size_t j = 0; j < subset_b.size(); ++j) {
      const int d = hamming(da, b[std::size_t(subset_b[j])]);
      if (d < d1) {
        d2 = d1, d1 = d, best = int(j);
      } else if (d < d2) {
        d2 = d;
      }
    }
    rule.offer(int(i), best, d1, d2, options);
  }
  std::vector<std::pair<int, int>> matches;
  for (const auto& [i, j] : rule.resolve()) matches.push_back({subset_a[std::size_t(i)], subset_b[std::size_t(j)]});
  return matches;
}

PANOSCAN_POPCNT_CLONES std::vector<std::pair<int, int>>
match_orb_among(const std::vector<OrbDescriptor>& a, const std::vector<OrbDescriptor>& b,
                const std::vector<int>& candidate_offsets, const std::vector<int>& candidates,
                const OrbMatchOptions& options) {
  if (candidate_offsets.size() != a.size() + 1)
    throw std::invalid_argument("match_orb_among: candidate_offsets needs one entry per descriptor of a, plus one");
  OneAPerB rule(b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    int best = -1, d1 = 1 << 20, d2 = 1 << 20;
    for (int k = candidate_offsets[i]; k < candidate_offsets[i + 1]; ++k) {
      const int j = candidates[std::size_t(k)];
      const int d = hamming(a[i], b[std::size_t(j)]);
      if (d < d1) {
        d2 = d1, d1 = d, best = j;
      } else if (d < d2) {
        d2 = d;
      }
    }
    rule.offer(int(i), best, d1, d2, options);
  }
  return rule.resolve();
}

std::vector<std::pair<int, int>> match_orb(const std::vector<OrbDescriptor>& a, const std::vector<OrbDescriptor>& b,
                                           const OrbMatchOptions& options) {
  std::vector<int> all_a(a.size()), all_b(b.size());
  std::iota(all_a.begin(), all_a.end(), 0);
  std::iota(all_b.begin(), all_b.end(), 0);
  return match_orb(a, all_a, b, all_b, options);
}

}  // namespace panoscan
