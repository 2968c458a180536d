// Embree ray-casting renderer of a scene for pinhole cameras: z-depth, shaded textured colour,
// incidence angle, and the id of the hit triangle. Thread-safe: render() may run concurrently.
#pragma once

#include <memory>

#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/mesh.h"

namespace panoscan {

struct RenderedView {
  ImageF32 depth;          // z along the optical axis in metres; 0 where the ray hits nothing
  ImageU8 rgb;             // shaded colour
  ImageF32 incidence_cos;  // |cos(angle between ray and surface normal)|
  ImageI32 triangle_id;    // index into the scene mesh's triangles; -1 where nothing is hit
};

struct RenderRequest {
  bool depth = true;
  bool colour = true;
  bool triangle_ids = true;
};

class Renderer {
 public:
  explicit Renderer(const Scene& scene);  // keeps a reference to `scene`: it must outlive this
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders rows [row_begin, row_end) of the view into `out` (allocated by the caller via
  // allocate()); lets callers parallelise over rows.
  void render_rows(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin, int row_end,
                   RenderedView& out) const;
  // Whole view, parallel over rows (oneTBB).
  RenderedView render(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics) const;
  static RenderedView allocate(const PinholeIntrinsics& intrinsics);

  // Noiseless equirectangular panorama seen from the origin of `world_from_pano` (its z axis is
  // the panorama's up direction): `depth` holds the radial distance (not z), colour and ids as
  // above, `incidence_cos` likewise. Used for ground-truth panoramas.
  RenderedView render_equirectangular(const Rigid3d& world_from_pano, const Equirectangular& pano) const;

  // Bare Embree intersection of the same rays (reference for the speed benchmark): returns the
  // number of hits.
  std::size_t intersect_only(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin,
                             int row_end) const;

  // The same with coherent packets of 8 rays (rtcIntersect8): Embree's faster path.
  std::size_t intersect_only_packets(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin,
                                     int row_end) const;

  // First hit along a ray from `origin` in direction `direction` (unit); distance or -1.
  double cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int* triangle = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace panoscan
