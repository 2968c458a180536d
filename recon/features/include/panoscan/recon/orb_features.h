// ORB features with one behaviour for every user: the tracking front end (recon/frontend, keys
// frontend.*) and the registration's initial guess (recon/registration, keys features.*).
//
// Detection: OpenCV's ORB (FAST corners on an image pyramid, Harris score, rotated BRIEF on a
// patch_px patch), on the grey image of an RGB or grey frame.
// Matching: each descriptor of a with its nearest descriptor of b (Hamming), kept when
//  - the distance is at most max_hamming,
//  - Lowe's ratio test passes (nearest < ratio x second nearest among b), and
//  - no other a that chose the same b is closer to it (one a per b; the first on a tie).
// (The registration's guess used the ratio test in both directions with a mutual check; on the
// tracking that rule lost landmarks and moved cam2's extrinsics 0.5 -> 0.69 deg on a test scan, and
// with it the guess needs no distance limit: features.max_hamming is 256 there.)
// Matches are returned in increasing order of a's index; the result does not depend on threads.
// The 3D-3D verification that follows is core's rigid_ransac (panoscan/core/rigid_ransac.h).
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "panoscan/core/image.h"

namespace panoscan {

using OrbDescriptor = std::array<std::uint8_t, 32>;

struct OrbKeypoint {
  float u = 0, v = 0;  // pixel (OpenCV convention: centre of the top-left pixel at 0, 0)
  int octave = 0;      // pyramid level (localisation std ~ scale_factor^octave px)
};

struct OrbDetectorOptions {
  int features = 1000;        // keypoints wanted
  double scale_factor = 1.2;  // pyramid scale between levels
  int levels = 8;             // pyramid levels
  int fast_threshold = 20;    // FAST intensity threshold
  int patch_px = 31;          // descriptor patch (and ORB's default border)
  int border_px = 0;          // keypoints at least this far from the border (0 = patch_px)
};

// Keypoints and descriptors of an 8-bit image with 1 or 3 (RGB) channels.
void detect_orb(const ImageU8& image, const OrbDetectorOptions& options, std::vector<OrbKeypoint>* keypoints,
                std::vector<OrbDescriptor>* descriptors);

struct OrbMatchOptions {
  int max_hamming = 64;  // of 256 bits
  double ratio = 0.8;    // Lowe's ratio test
};

// Hamming distance of two descriptors.
int hamming_distance(const OrbDescriptor& a, const OrbDescriptor& b);

// Matches (index in a, index in b) between the subsets of a's and b's descriptors (indices into
// a and b), with the behaviour above.
std::vector<std::pair<int, int>> match_orb(const std::vector<OrbDescriptor>& a, const std::vector<int>& subset_a,
                                           const std::vector<OrbDescriptor>& b, const std::vector<int>& subset_b,
                                           const OrbMatchOptions& options);
// The same over all descriptors.
std::vector<std::pair<int, int>> match_orb(const std::vector<OrbDescriptor>& a, const std::vector<OrbDescriptor>& b,
                                           const OrbMatchOptions& options);
// Matches (index in a, index in b) where each a is compared only with its own candidates in b:
// candidates[candidate_offsets[i] .. candidate_offsets[i + 1]) are indices into b for a's index i
// (candidate_offsets has a.size() + 1 entries). The same rules, the ratio test among the
// candidates; a guided search (e.g. around a keypoint's predicted position) passes its window here.
std::vector<std::pair<int, int>> match_orb_among(const std::vector<OrbDescriptor>& a,
                                                 const std::vector<OrbDescriptor>& b,
                                                 const std::vector<int>& candidate_offsets,
                                                 const std::vector<int>& candidates, const OrbMatchOptions& options);

}  // namespace panoscan
