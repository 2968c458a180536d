// Open3D's GICP, hashed TSDF volume and RGB-D odometry, for the baselines and the outside references
// (Tables 1, 3 and 4, the speed benchmarks), as a module that PanoScan loads the first time one of
// them runs (open3d_calls.cpp). Linked into every program, Open3D brought ~100 shared libraries and
// ~0.04 s to the start of every process, which most never use.
#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>
#include <open3d/pipelines/odometry/Odometry.h>
#include <open3d/pipelines/registration/GeneralizedICP.h>
#include <open3d/utility/Logging.h>

#include "open3d_table.h"

namespace {

namespace o3d = open3d;
using panoscan::open3d_module::FrameView;
using panoscan::open3d_module::GicpResult;
using panoscan::open3d_module::Intrinsics;
using panoscan::open3d_module::TsdfMesh;

// Runs `body`; an exception becomes `false` with its text in `error`.
template <class Body>
bool guarded(std::string* error, Body&& body) {
  try {
    body();
    return true;
  } catch (const std::exception& e) {
    *error = e.what();
  } catch (...) {
    *error = "unknown exception";
  }
  return false;
}

// Quietens Open3D's warnings for the guard's lifetime (a failed odometry step is counted instead).
class ErrorsOnly {
 public:
  ErrorsOnly() : previous_(o3d::utility::GetVerbosityLevel()) {
    o3d::utility::SetVerbosityLevel(o3d::utility::VerbosityLevel::Error);
  }
  ~ErrorsOnly() { o3d::utility::SetVerbosityLevel(previous_); }
  ErrorsOnly(const ErrorsOnly&) = delete;
  ErrorsOnly& operator=(const ErrorsOnly&) = delete;

 private:
  o3d::utility::VerbosityLevel previous_;
};

o3d::camera::PinholeCameraIntrinsic intrinsic_of(const Intrinsics& k) {
  return o3d::camera::PinholeCameraIntrinsic(k.width, k.height, k.fx, k.fy, k.cx, k.cy);
}

// Open3D's RGB-D image of a frame: colour as is, depth in metres with no-measurement as 0.
std::shared_ptr<o3d::geometry::RGBDImage> rgbd_of(const FrameView& frame, double max_depth_m, bool intensity) {
  o3d::geometry::Image colour, depth;
  const std::size_t pixels = std::size_t(frame.width) * frame.height;
  colour.Prepare(frame.width, frame.height, 3, 1);
  std::copy(frame.rgb, frame.rgb + 3 * pixels, colour.data_.begin());
  depth.Prepare(frame.width, frame.height, 1, 4);
  float* d = depth.PointerAs<float>();
  for (std::size_t i = 0; i < pixels; ++i) {
    const float z = frame.depth_m[i];
    d[i] = (std::isfinite(z) && z > 0.f) ? z : 0.f;
  }
  // depth_scale 1: the depth is already in metres.
  return o3d::geometry::RGBDImage::CreateFromColorAndDepth(colour, depth, 1.0, max_depth_m, intensity);
}

bool gicp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
          double max_correspondence_m, const Eigen::Matrix4d& initial_target_from_source, int max_iterations,
          GicpResult* out, std::string* error) {
  return guarded(error, [&] {
    o3d::geometry::PointCloud open3d_source, open3d_target;
    open3d_source.points_ = source;
    open3d_target.points_ = target;
    namespace reg = o3d::pipelines::registration;
    const reg::RegistrationResult result = reg::RegistrationGeneralizedICP(
        open3d_source, open3d_target, max_correspondence_m, initial_target_from_source,
        reg::TransformationEstimationForGeneralizedICP(), reg::ICPConvergenceCriteria(1e-6, 1e-6, max_iterations));
    out->target_from_source = result.transformation_;
    out->fitness = result.fitness_;
    out->inlier_rmse = result.inlier_rmse_;
    out->correspondences = result.correspondence_set_.size();
  });
}

using Volume = o3d::pipelines::integration::ScalableTSDFVolume;

void* tsdf_new(double voxel_m, double truncation_m) {
  return new Volume(voxel_m, truncation_m, o3d::pipelines::integration::TSDFVolumeColorType::RGB8);
}

bool tsdf_integrate(void* volume, const FrameView& frame, double max_depth_m, const Intrinsics& k,
                    const Eigen::Matrix4d& cam_from_world, std::string* error) {
  return guarded(error, [&] {
    static_cast<Volume*>(volume)->Integrate(*rgbd_of(frame, max_depth_m, false), intrinsic_of(k), cam_from_world);
  });
}

bool tsdf_extract(void* volume, TsdfMesh* out, std::string* error) {
  return guarded(error, [&] {
    Volume& v = *static_cast<Volume*>(volume);
    const auto mesh = v.ExtractTriangleMesh();
    out->vertices = mesh->vertices_;
    out->colours = mesh->HasVertexColors() ? mesh->vertex_colors_ : std::vector<Eigen::Vector3d>();
    out->triangles = mesh->triangles_;
    out->volume_units = v.volume_units_.size();
    out->unit_resolution = v.volume_unit_resolution_;
  });
}

void tsdf_delete(void* volume) { delete static_cast<Volume*>(volume); }

void* rgbd_new(const FrameView& frame, double max_depth_m, bool intensity, std::string* error) {
  std::shared_ptr<o3d::geometry::RGBDImage> image;
  if (!guarded(error, [&] {
        ErrorsOnly quiet;
        image = rgbd_of(frame, max_depth_m, intensity);
      }))
    return nullptr;
  return new std::shared_ptr<o3d::geometry::RGBDImage>(std::move(image));
}

void rgbd_delete(void* image) { delete static_cast<std::shared_ptr<o3d::geometry::RGBDImage>*>(image); }

bool rgbd_odometry(const void* current, const void* previous, const Intrinsics& k, const Eigen::Matrix4d& initial,
                   const std::vector<int>& iterations_per_level, double max_depth_difference_m, double min_depth_m,
                   double max_depth_m, bool* converged, Eigen::Matrix4d* previous_from_current, std::string* error) {
  return guarded(error, [&] {
    ErrorsOnly quiet;
    const o3d::pipelines::odometry::OdometryOption option(iterations_per_level, max_depth_difference_m, min_depth_m,
                                                          max_depth_m);
    const o3d::pipelines::odometry::RGBDOdometryJacobianFromHybridTerm hybrid;
    const auto& current_image = **static_cast<const std::shared_ptr<o3d::geometry::RGBDImage>*>(current);
    const auto& previous_image = **static_cast<const std::shared_ptr<o3d::geometry::RGBDImage>*>(previous);
    // Open3D returns the transformation taking the source (current) frame's points into the target
    // (previous) frame.
    const auto [ok, step, information] = o3d::pipelines::odometry::ComputeRGBDOdometry(
        current_image, previous_image, intrinsic_of(k), initial, hybrid, option);
    (void)information;
    *converged = ok;
    *previous_from_current = step;
  });
}

const panoscan::open3d_module::Table kTable = {panoscan::open3d_module::kTableVersion,
                                               gicp,
                                               tsdf_new,
                                               tsdf_integrate,
                                               tsdf_extract,
                                               tsdf_delete,
                                               rgbd_new,
                                               rgbd_delete,
                                               rgbd_odometry};

}  // namespace

extern "C" const panoscan::open3d_module::Table* panoscan_open3d_table() { return &kTable; }
