// Cross-camera correspondences in the narrow overlap band (internal to the front end; issue 16,
// recon/tracking/README.md "Cross-camera matching").
//
// ORB cannot match across a band a few pixels wide: its 31-px descriptor patch does not fit, and
// near the border it describes reflected padding. So the band is matched by direct patch
// alignment instead:
//  1. Where the views meet follows from the calibration (Relation: the pixels of camera a that
//     see into camera b, and of b into a; camera pairs that never overlap get no relation).
//  2. The transform between a frame of a and a frame of b taken at another instant is predicted
//     from the calibration and the rig's rotation between the two shutter times, read off the
//     chain of verified same-camera transforms of either camera (CameraChains::motion).
//  3. Band alignment (estimate_band_correction): the calibration's error (0.5-1 deg, 5-10 px) is
//     larger than the band is wide (4-8 px: the cameras' 6-cm offset costs the nominal 16 px of
//     overlap at +-44 deg about 10 px at 2.5 m), so its rotation is found first, once per camera
//     pair: small patches of a (long along the band, short across it), warped into b with their
//     depth, are slid over b; each patch with a distinct correlation peak votes for its shift, and
//     the rotation most votes agree with corrects the calibration for the search below (only for
//     the search: the tracking refines T_c from the matches, Eq. 1-2).
//  4. Per frame pair (match_band_pair): each corner of a whose predicted position lies inside b
//     is aligned within a few pixels (NCC peak, sub-pixel by a parabola), checked for a
//     correlation floor, a consistent shift across the pair and the depth b measures there.
// The matches become keypoints of both frames and join the landmarks, so Eq. 1 ties the cameras.
#pragma once

#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/frontend.h"

namespace panoscan::cross_camera {

struct Pixel {
  int x = 0, y = 0;
};
struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;
};

// Two cameras whose views overlap (a < b), with the regions of each image that see into the other
// (widened by the search margin). The band runs along x when the region of a is wider than high.
struct Relation {
  int sensor_a = 0, sensor_b = 0;
  PixelRect roi_a, roi_b;
  bool along_x = true;
  Rigid3d b_from_a_calibrated = Rigid3d::Identity();
};

// The overlapping camera pairs of the rig, from the calibrated extrinsics; pairs that never
// overlap (the top and bottom cameras) have none.
std::vector<Relation> overlapping_relations(const ScanIndex& scan, const std::vector<char>& used,
                                            const FrontendOptions& options);

// A frame's view of one relation: grey (0-255) and depth (metres) inside the
// relation's region, and its corners (local maxima of the minimum eigenvalue, strongest first).
struct BandCrop {
  PixelRect roi;
  // Only camera b's crop keeps its pixels: a's are read once, for its patches' templates and depths.
  // The front end holds a crop of every frame until the cross-camera matching (a full 640x480 scan:
  // 2880 frames), and a's pixels were half of the crops' memory.
  ImageF32 gray, depth;
  std::vector<Pixel> corners;  // in full-image pixels; only for the relation's camera a
  // Camera a's corners that make a usable patch (inside the crop, with depth, contrast and texture
  // in both directions), strongest first, each with its zero-mean, unit-norm template: computed
  // once per frame, not once per frame of b the patch is aligned with (band_frames of them and the
  // calibration's sample: this was a tenth of the front end's instructions).
  struct Patch {
    Pixel pixel;
    float depth = 0;
  };
  std::vector<Patch> patches;
  std::vector<float> templates;  // patches.size() x patch_pixels, row by row
  int patch_pixels = 0;
};
// camera_a: the crop of the relation's camera a (corners and patch templates, no pixels) or b (pixels only).
BandCrop make_band_crop(const RgbdFrame& frame, const Relation& relation, bool camera_a,
                        const FrontendOptions& options);

// Poses of each camera's frames along chains of verified same-camera transforms (a frame without a
// pair to an earlier frame of its chain starts a new chain).
struct CameraChains {
  std::vector<std::vector<Rigid3d>> chain_from_frame;  // per sensor, per frame
  std::vector<std::vector<int>> chain_of_frame;        // per sensor, per frame; -1 = sensor unused
  std::vector<std::vector<double>> timestamps;         // per sensor, per frame
  // cam(t1)_from_cam(t2) of `sensor`, interpolated between its frames (rotation on SO(3), translation
  // linearly); false unless both instants lie between frames of one chain.
  bool motion(int sensor, double t1, double t2, Rigid3d* cam1_from_cam2) const;
};

// cam_b(frame g)_from_cam_a(frame f), predicted from the (corrected) calibration and the rig's motion
// between the two shutter times (camera a's chain, else b's; frames closer than same_time_s in time
// need neither). False when neither chain covers both instants.
bool predict_b_from_a(const CameraChains& chains, const Relation& relation, const Rigid3d& b_from_a_at_one_instant,
                      int frame_a, int frame_b, Rigid3d* b_from_a);

// Step 3: the calibration's rotation error as seen by the band (b's observed directions ~ result *
// predicted ones), from the sampled frame pairs (frame of a, frame of b) with their crops. Sets
// *agreeing_votes; returns identity when the votes do not single out one rotation.
Eigen::Matrix3d estimate_band_correction(const Relation& relation, const CameraChains& chains,
                                         const std::vector<std::pair<int, int>>& frame_pairs,
                                         const std::vector<const BandCrop*>& crops_a,
                                         const std::vector<const BandCrop*>& crops_b, const ScanIndex& scan,
                                         const FrontendOptions& options, int* agreeing_votes);

struct BandMatch {
  Keypoint in_a, in_b;
};
struct BandPairResult {
  int anchors = 0;                         // corners of a predicted inside b
  int aligned = 0;                         // that reached the correlation floor
  std::vector<BandMatch> matches;          // after the shift-consistency and depth checks
  Rigid3d a_from_b = Rigid3d::Identity();  // the prediction with its rotation fitted to the matches
};
// Step 4 for one frame pair, given the predicted cam_b_from_cam_a.
BandPairResult match_band_pair(const Relation& relation, const Rigid3d& b_from_a, const BandCrop& crop_a,
                               const BandCrop& crop_b, const ScanIndex& scan, const FrontendOptions& options);

}  // namespace panoscan::cross_camera
