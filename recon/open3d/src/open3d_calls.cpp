#include "panoscan/recon/open3d_calls.h"

#include <mutex>
#include <utility>

#include "open3d_table.h"
#include "panoscan/core/error.h"
#include "panoscan/core/module.h"

namespace panoscan::open3d_calls {

namespace {

using open3d_module::FrameView;
using open3d_module::Intrinsics;
using open3d_module::Table;

// The module's table, loaded on the first call (the path is compiled in, as CMake's build-tree
// RUNPATHs are).
const Table& table() {
  static std::once_flag once;
  static const Table* loaded = nullptr;
  static std::string load_error;
  std::call_once(once, [] {
    using TableFunction = const Table* (*)();
    const auto get = reinterpret_cast<TableFunction>(
        load_module_symbol(PANOSCAN_OPEN3D_MODULE, kPanoscanOpen3dTableSymbol, &load_error));
    if (get == nullptr) return;
    const Table* candidate = get();
    if (candidate->version != open3d_module::kTableVersion) {
      load_error = std::string(PANOSCAN_OPEN3D_MODULE) + " is of another build (table version " +
                   std::to_string(candidate->version) + ", expected " + std::to_string(open3d_module::kTableVersion) +
                   "): rebuild";
      return;
    }
    loaded = candidate;
  });
  if (loaded == nullptr) throw make_error("open3d", "", "cannot load PanoScan's Open3D module (" + load_error + ")");
  return *loaded;
}

void check(bool ok, const std::string& what, const std::string& error) {
  if (!ok) throw make_error("open3d", what, error);
}

Intrinsics intrinsics_of(const PinholeIntrinsics& k) { return {k.width, k.height, k.fx, k.fy, k.cx, k.cy}; }

FrameView view_of(const RgbdFrame& frame) {
  if (frame.rgb.width != frame.depth.width || frame.rgb.height != frame.depth.height || frame.rgb.channels != 3)
    throw make_error("open3d", "frame", "colour and depth of different sizes, or colour without 3 channels");
  return {frame.rgb.width, frame.rgb.height, frame.rgb.data.data(), frame.depth.data.data()};
}

}  // namespace

void load() { table(); }

GicpResult generalized_icp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                           double max_correspondence_m, const Eigen::Matrix4d& initial_target_from_source,
                           int max_iterations) {
  GicpResult out;
  std::string error;
  check(table().gicp(source, target, max_correspondence_m, initial_target_from_source, max_iterations, &out, &error),
        "generalized ICP", error);
  return out;
}

TsdfVolume::TsdfVolume(double voxel_m, double truncation_m) : volume_(table().tsdf_new(voxel_m, truncation_m)) {}

TsdfVolume::~TsdfVolume() { table().tsdf_delete(volume_); }

void TsdfVolume::integrate(const RgbdFrame& frame, double max_depth_m, const PinholeIntrinsics& k,
                           const Eigen::Matrix4d& cam_from_world) {
  std::string error;
  check(table().tsdf_integrate(volume_, view_of(frame), max_depth_m, intrinsics_of(k), cam_from_world, &error),
        "TSDF integration", error);
}

TsdfMesh TsdfVolume::extract_mesh() const {
  TsdfMesh out;
  std::string error;
  check(table().tsdf_extract(volume_, &out, &error), "TSDF mesh", error);
  return out;
}

RgbdImage::RgbdImage(const RgbdFrame& frame, double max_depth_m, bool intensity) : image_(nullptr) {
  std::string error;
  image_ = table().rgbd_new(view_of(frame), max_depth_m, intensity, &error);
  check(image_ != nullptr, "RGB-D image", error);
}

RgbdImage::~RgbdImage() {
  if (image_ != nullptr) table().rgbd_delete(image_);
}

RgbdImage::RgbdImage(RgbdImage&& other) noexcept : image_(std::exchange(other.image_, nullptr)) {}

RgbdImage& RgbdImage::operator=(RgbdImage&& other) noexcept {
  if (this != &other) {
    if (image_ != nullptr) table().rgbd_delete(image_);
    image_ = std::exchange(other.image_, nullptr);
  }
  return *this;
}

OdometryStep rgbd_odometry(const RgbdImage& current, const RgbdImage& previous, const PinholeIntrinsics& k,
                           const Eigen::Matrix4d& initial, const std::vector<int>& iterations_per_level,
                           double max_depth_difference_m, double min_depth_m, double max_depth_m) {
  OdometryStep step;
  std::string error;
  check(table().rgbd_odometry(current.handle(), previous.handle(), intrinsics_of(k), initial, iterations_per_level,
                              max_depth_difference_m, min_depth_m, max_depth_m, &step.converged,
                              &step.previous_from_current, &error),
        "RGB-D odometry", error);
  return step;
}

}  // namespace panoscan::open3d_calls
