// Embree ray-casting renderer of a scene for pinhole cameras: z-depth, shaded textured colour,
// incidence angle, the id of the hit triangle, and on request its normal in the camera frame.
// Thread-safe: render() may run concurrently.
#pragma once

#include <atomic>
#include <cstdint>
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
  ImageI32 triangle_id;    // index into the scene mesh's triangles; -1 where nothing is hit (empty
                           // without RenderRequest::triangle_ids)
  // Only with RenderRequest::normals (empty otherwise): the hit triangle's geometric unit normal in
  // the camera frame (cam_from_world rotation of the world normal), turned to face the camera (its
  // dot product with the pixel's ray is negative); 3 channels x, y, z; 0 where nothing is hit.
  ImageF32 normal_cam;
};

// What a pinhole render produces beyond depth and incidence (always made).
struct RenderRequest {
  bool normals = false;  // normal_cam: off by default, so views that do not need it skip the per-pixel cost
  bool colour = true;    // rgb: false leaves it black and skips the texture and lighting (depth-only views)
  bool triangle_ids = true;  // triangle_id: false leaves it empty (the simulator writes ids only with --ids)
};

// Where render() / render_rows() spend their time, for the simulator's stage breakdown: thread
// nanoseconds, added atomically because views render concurrently. Optional (a null pointer costs nothing).
struct RenderTimes {
  std::atomic<std::int64_t> rays_ns{0};     // Embree: setting up and intersecting the primary ray packets
  std::atomic<std::int64_t> shading_ns{0};  // per hit: depth, ids, incidence, normals, texture, lights
};

class Renderer {
 public:
  explicit Renderer(const Scene& scene);  // keeps a reference to `scene`: it must outlive this
  explicit Renderer(Scene&& scene) = delete;  // so a temporary scene does not compile
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders rows [row_begin, row_end) of the view into `out` (allocated by the caller via
  // allocate() with the same request); lets callers parallelise over rows.
  void render_rows(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin, int row_end,
                   RenderedView& out, const RenderRequest& request = {}, RenderTimes* times = nullptr) const;
  // Whole view, parallel over rows (oneTBB).
  RenderedView render(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics,
                      const RenderRequest& request = {}, RenderTimes* times = nullptr) const;
  static RenderedView allocate(const PinholeIntrinsics& intrinsics, const RenderRequest& request = {});
  // The same view shaded one pixel at a time (the same ray packets, then the scalar shading code
  // the panorama renderer uses): the reference render() must match bit for bit. Slower; for tests.
  RenderedView render_per_pixel(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics,
                                const RenderRequest& request = {}) const;

  // Noiseless equirectangular panorama seen from the origin of `world_from_pano` (its z axis is
  // the panorama's up direction): `depth` holds the radial distance (not z), colour and ids as
  // above, `incidence_cos` likewise, no normals. Used for ground-truth panoramas.
  RenderedView render_equirectangular(const Rigid3d& world_from_pano, const Equirectangular& pano) const;

  // Bare Embree intersection of the same rays (reference for the speed benchmark): returns the
  // number of hits.
  std::size_t intersect_only(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin,
                             int row_end) const;

  // The same with coherent packets of 8 rays (rtcIntersect8, 8 neighbouring pixels of a row):
  // Embree's faster path, the speed report's reference.
  std::size_t intersect_only_packets(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics, int row_begin,
                                     int row_end) const;
  // With packets of 16 (rtcIntersect16), as render_rows traces them.
  std::size_t intersect_only_packets16(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics,
                                       int row_begin, int row_end) const;

  // First hit along a ray from `origin` in direction `direction` (unit); distance or -1.
  double cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int* triangle = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace panoscan
