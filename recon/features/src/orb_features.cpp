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

namespace {

// Nearest and second-nearest distance (and the nearest's index) of one descriptor.
struct Nearest {
  int index = -1, d1 = 1 << 20, d2 = 1 << 20;
  void offer(int candidate, int d) {
    if (d < d1) {
      d2 = d1, d1 = d, index = candidate;
    } else if (d < d2) {
      d2 = d;
    }
  }
  bool passes(const OrbMatchOptions& o) const { return index >= 0 && d1 <= o.max_hamming && d1 < o.ratio * d2; }
};

}  // namespace

// Debian builds for the x86-64 baseline, which has no POPCNT instruction: __builtin_popcountll
// becomes a libgcc call that took 7% of a tracking run. A clone for CPUs with POPCNT is picked at
// load time (GCC function multi-versioning); other CPUs run the baseline clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
std::vector<std::pair<int, int>>
match_orb(const std::vector<OrbDescriptor>& a, const std::vector<int>& subset_a, const std::vector<OrbDescriptor>& b,
          const std::vector<int>& subset_b, const OrbMatchOptions& options) {
  // One pass over all distances fills the nearest neighbours in both directions.
  std::vector<Nearest> of_a(subset_a.size()), of_b(subset_b.size());
  for (std::size_t i = 0; i < subset_a.size(); ++i) {
    const OrbDescriptor& da = a[std::size_t(subset_a[i])];
    for (std::size_t j = 0; j < subset_b.size(); ++j) {
      const int d = hamming(da, b[std::size_t(subset_b[j])]);
      of_a[i].offer(int(j), d);
      of_b[j].offer(int(i), d);
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (std::size_t i = 0; i < subset_a.size(); ++i) {
    if (!of_a[i].passes(options)) continue;
    const Nearest& back = of_b[std::size_t(of_a[i].index)];
    if (!back.passes(options) || back.index != int(i)) continue;
    matches.push_back({subset_a[i], subset_b[std::size_t(of_a[i].index)]});
  }
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
