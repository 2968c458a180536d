// Closest point on a triangle mesh through Embree's point queries (rtcPointQuery).
//
// Embree traverses its BVH with a sphere (query point, radius) and calls our callback for every
// triangle whose bounds meet the sphere. The callback computes the exact point-triangle distance
// in double precision and shrinks the sphere to it, so the traversal prunes everything farther.
// Embree works in float: the query point it sees is the float rounding of ours, and its box
// tests round too. To stay exact we never shrink the radius to the bare distance but add a slack
// of a few float ulps of the coordinates' magnitude: a triangle at the true minimum distance can
// then never be culled, and the minimum over the visited triangles is the exact minimum.

#include "panoscan/eval/mesh_distance.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/cpu_features.h"
#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"

namespace panoscan::eval {

namespace {

struct TriangleCorners {
  Eigen::Vector3d a, b, c;
};

// What one query carries through Embree to the callback.
struct QueryState {
  const TriangleCorners* triangles = nullptr;
  Eigen::Vector3d point;
  double best_distance = std::numeric_limits<double>::infinity();
  Eigen::Vector3d best_point = Eigen::Vector3d::Zero();
  unsigned best_triangle = RTC_INVALID_GEOMETRY_ID;
  double radius_slack = 0.0;
};

// Radius handed back to Embree for an exact distance d: never below d even after Embree's float
// arithmetic (see the file comment).
float conservative_radius(double distance, double slack) {
  const float radius = static_cast<float>(distance + slack);
  return std::nextafter(radius, std::numeric_limits<float>::infinity());
}

bool closest_triangle_callback(RTCPointQueryFunctionArguments* args) {
  auto* state = static_cast<QueryState*>(args->userPtr);
  const unsigned id = args->primID;
  const TriangleCorners& t = state->triangles[id];
  Eigen::Vector3d closest;
  const double d = point_triangle_distance(state->point, t.a, t.b, t.c, &closest);
  // Ties go to the lowest triangle index so that the reported triangle does not depend on the
  // traversal order.
  if (d < state->best_distance || (d == state->best_distance && id < state->best_triangle)) {
    const bool shrinks = d < state->best_distance;
    state->best_distance = d;
    state->best_point = closest;
    state->best_triangle = id;
    if (shrinks) {
      const float radius = conservative_radius(d, state->radius_slack);
      if (radius < args->query->radius) {
        args->query->radius = radius;
        return true;  // the query sphere changed: Embree re-culls with it
      }
    }
  }
  return false;
}

double triangle_area(const TriangleCorners& t) { return 0.5 * (t.b - t.a).cross(t.c - t.a).norm(); }

}  // namespace

struct MeshDistance::Impl {
  TriangleMesh mesh;
  std::string origin;
  std::vector<TriangleCorners> triangles;
  double area = 0.0;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  void check_embree(const char* step) const {
    const RTCError code = rtcGetDeviceError(device);
    if (code != RTC_ERROR_NONE)
      throw make_error(
          origin, "",
          std::string("Embree failed to ") + step + " (error code " + std::to_string(static_cast<int>(code)) + ")");
  }
};

MeshDistance::MeshDistance(const TriangleMesh& mesh, const std::string& origin) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.mesh = mesh;
  m.origin = origin;
  const std::size_t num_vertices = mesh.vertices.size();
  if (mesh.triangles.empty()) throw make_error(origin, "triangles", "the mesh has no triangles");
  for (std::size_t i = 0; i < num_vertices; ++i)
    if (!mesh.vertices[i].allFinite()) throw make_error(origin, "vertex " + std::to_string(i), "non-finite coordinate");
  m.triangles.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tri[k] < 0 || static_cast<std::size_t>(tri[k]) >= num_vertices)
        throw make_error(
            origin, "triangle " + std::to_string(t),
            "vertex index " + std::to_string(tri[k]) + " out of range (" + std::to_string(num_vertices) + " vertices)");
    m.triangles[t] = {mesh.vertices[tri[0]].cast<double>(), mesh.vertices[tri[1]].cast<double>(),
                      mesh.vertices[tri[2]].cast<double>()};
    m.area += triangle_area(m.triangles[t]);
  }

  m.device = rtcNewDevice(cpu::embree_device_config().c_str());
  if (!m.device) throw make_error(origin, "", "cannot create an Embree device");
  m.scene = rtcNewScene(m.device);
  // Robust mode: occlusion rays do not slip through shared edges (visibility of samples).
  rtcSetSceneFlags(m.scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(m.scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertex_buffer = static_cast<float*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), num_vertices));
  auto* index_buffer = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangles.size()));
  if (!vertex_buffer || !index_buffer) {
    rtcReleaseGeometry(geometry);
    m.check_embree("allocate the mesh buffers");
    throw make_error(origin, "", "Embree could not allocate the mesh buffers");
  }
  for (std::size_t i = 0; i < num_vertices; ++i)
    for (int k = 0; k < 3; ++k) vertex_buffer[3 * i + k] = mesh.vertices[i][k];
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) index_buffer[3 * t + k] = static_cast<unsigned>(mesh.triangles[t][k]);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(m.scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(m.scene);
  m.check_embree("build the BVH");
}

MeshDistance::~MeshDistance() = default;

ClosestPoint MeshDistance::closest(const Eigen::Vector3d& point) const {
  const Impl& m = *impl_;
  if (!point.allFinite()) throw make_error(m.origin, "query point", "non-finite coordinate");
  QueryState state;
  state.triangles = m.triangles.data();
  state.point = point;
  // A few float ulps of the largest coordinate involved (see the file comment).
  state.radius_slack = 8.0 * FLT_EPSILON * (point.cwiseAbs().maxCoeff() + 1.0);

  RTCPointQuery query;
  query.x = static_cast<float>(point.x());
  query.y = static_cast<float>(point.y());
  query.z = static_cast<float>(point.z());
  query.time = 0.f;
  query.radius = std::numeric_limits<float>::infinity();
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(m.scene, &query, &context, closest_triangle_callback, &state);

  if (state.best_triangle == RTC_INVALID_GEOMETRY_ID) {
    // Cannot happen for a valid mesh (an infinite sphere meets every triangle); fall back to the
    // exhaustive search rather than report a wrong distance.
    return closest_point_brute_force(m.mesh, point);
  }
  ClosestPoint result;
  result.distance = state.best_distance;
  result.point = state.best_point;
  result.triangle = static_cast<int>(state.best_triangle);
  return result;
}

std::vector<double> MeshDistance::distances(const std::vector<Eigen::Vector3d>& points,
                                            const std::string& origin) const {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite()) throw make_error(origin, "point " + std::to_string(i), "non-finite coordinate");
  std::vector<double> result(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i)
                        result[i] = closest(points[i]).distance;
                    });
  return result;
}

bool MeshDistance::segment_blocked(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double end_margin_m) const {
  const Eigen::Vector3d direction = to - from;
  const double length = direction.norm();
  if (!(length > end_margin_m)) return false;  // nothing left to block
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = static_cast<float>(from.x());
  ray.org_y = static_cast<float>(from.y());
  ray.org_z = static_cast<float>(from.z());
  const Eigen::Vector3d unit = direction / length;
  ray.dir_x = static_cast<float>(unit.x());
  ray.dir_y = static_cast<float>(unit.y());
  ray.dir_z = static_cast<float>(unit.z());
  ray.tnear = 0.f;
  ray.tfar = static_cast<float>(length - end_margin_m);
  ray.time = 0.f;
  ray.mask = 0xFFFFFFFFu;  // Debian's Embree has ray masks compiled in: mask 0 would hit nothing
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &context, &ray);
  // Embree sets tfar to -inf when the ray is occluded.
  return ray.tfar < 0.f;
}

const TriangleMesh& MeshDistance::mesh() const { return impl_->mesh; }
const std::string& MeshDistance::origin() const { return impl_->origin; }
double MeshDistance::surface_area() const { return impl_->area; }

ClosestPoint closest_point_brute_force(const TriangleMesh& mesh, const Eigen::Vector3d& point) {
  ClosestPoint best;
  best.distance = std::numeric_limits<double>::infinity();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    Eigen::Vector3d closest;
    const double d =
        point_triangle_distance(point, mesh.vertices[tri[0]].cast<double>(), mesh.vertices[tri[1]].cast<double>(),
                                mesh.vertices[tri[2]].cast<double>(), &closest);
    if (d < best.distance) {
      best.distance = d;
      best.point = closest;
      best.triangle = static_cast<int>(t);
    }
  }
  return best;
}

}  // namespace panoscan::eval
