// The table of Open3D calls that open3d_module.cpp exports and open3d_calls.cpp loads: plain data
// in, plain data out, so that the module links Open3D and nothing of PanoScan. Both sides are built
// by this project with one compiler and one libstdc++, so std::vector, std::string and Eigen's
// fixed-size types cross the boundary as they are.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/recon/open3d_results.h"

namespace panoscan::open3d_module {

using open3d_calls::GicpResult;
using open3d_calls::TsdfMesh;

// Raised whenever the table's layout changes: a stale module is refused rather than misread.
constexpr int kTableVersion = 2;

struct Intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// A colour + depth frame: `rgb` 3 bytes per pixel, `depth_m` metres (0 or non-finite: no measurement).
struct FrameView {
  int width = 0, height = 0;
  const std::uint8_t* rgb = nullptr;
  const float* depth_m = nullptr;
};

// Every call that can fail returns false with `error` set (Open3D's exception text); handles are
// owned by the caller and freed with the matching delete.
struct Table {
  int version;
  bool (*gicp)(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
               double max_correspondence_m, const Eigen::Matrix4d& initial_target_from_source, int max_iterations,
               GicpResult* out, std::string* error);
  void* (*tsdf_new)(double voxel_m, double truncation_m);
  bool (*tsdf_integrate)(void* volume, const FrameView& frame, double max_depth_m, const Intrinsics& k,
                         const Eigen::Matrix4d& cam_from_world, std::string* error);
  bool (*tsdf_extract)(void* volume, TsdfMesh* out, std::string* error);
  void (*tsdf_delete)(void* volume);
  // `intensity`: the grey image Open3D's RGB-D odometry needs, instead of colour.
  void* (*rgbd_new)(const FrameView& frame, double max_depth_m, bool intensity, std::string* error);
  void (*rgbd_delete)(void* image);
  // Open3D's hybrid RGB-D odometry of `current` against `previous`, its warnings silenced.
  bool (*rgbd_odometry)(const void* current, const void* previous, const Intrinsics& k, const Eigen::Matrix4d& initial,
                        const std::vector<int>& iterations_per_level, double max_depth_difference_m, double min_depth_m,
                        double max_depth_m, bool* converged, Eigen::Matrix4d* previous_from_current,
                        std::string* error);
};

}  // namespace panoscan::open3d_module

// The module's one exported symbol.
extern "C" const panoscan::open3d_module::Table* panoscan_open3d_table();
constexpr const char* kPanoscanOpen3dTableSymbol = "panoscan_open3d_table";
