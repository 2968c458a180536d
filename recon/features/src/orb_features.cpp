// ORB detection and matching; see orb_features.h for the behaviour.
#include "panoscan/recon/orb_features.h"

#include <cstring>
#include <numeric>

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

}  // namespace

int hamming_distance(const OrbDescriptor& a, const OrbDescriptor& b) { return hamming(a, b); }

// Debian builds for the x86-64 baseline, which has no POPCNT instruction: __builtin_popcountll
// becomes a libgcc call that took 7% of a tracking run. A clone for CPUs with POPCNT is picked at
// load time (GCC function multi-versioning); other CPUs run the baseline clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
std::vector<std::pair<int, int>>
match_orb(const std::vector<OrbDescriptor>& a, const std::vector<int>& subset_a, const std::vector<OrbDescriptor>& b,
          const std::vector<int>& subset_b, const OrbMatchOptions& options) {
  // Each a's nearest b under the ratio test and the distance limit; each b then keeps the closest
  // of the a's that chose it (the first on a tie).
  std::vector<int> best_a_of_b(subset_b.size(), -1), best_distance_of_b(subset_b.size(), 1 << 20);
  std::vector<std::pair<int, int>> candidates;  // (position in subset_a, position in subset_b)
  std::vector<int> candidate_distance;
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
    if (best < 0 || d1 > options.max_hamming || !(d1 < options.ratio * d2)) continue;
    candidates.push_back({int(i), best});
    candidate_distance.push_back(d1);
    if (d1 < best_distance_of_b[std::size_t(best)]) {
      best_distance_of_b[std::size_t(best)] = d1;
      best_a_of_b[std::size_t(best)] = int(i);
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (const auto& [i, j] : candidates)
    if (best_a_of_b[std::size_t(j)] == i) matches.push_back({subset_a[std::size_t(i)], subset_b[std::size_t(j)]});
  return matches;
}

std::vector<std::pair<int, int>> match_orb(const std::vector<OrbDescriptor>& a, const std::vector<OrbDescriptor>& b,
                                           const OrbMatchOptions& options) {
  std::vector<int> all_a(a.size()), all_b(b.size());
  std::iota(all_a.begin(), all_a.end(), 0);
  std::iota(all_b.begin(), all_b.end(), 0);
  return match_orb(a, all_a, b, all_b, options);
}

}  // namespace panoscan
