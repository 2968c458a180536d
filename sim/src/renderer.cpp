#include "panoscan/sim/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>

#include <embree3/rtcore.h>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/core/cpu_features.h"
#include "row_lanes.h"

namespace panoscan {

struct Renderer::Impl {
  const Scene& scene;
  RTCDevice device = nullptr;
  RTCScene rtc_scene = nullptr;
  std::vector<Eigen::Vector3f> triangle_normals;  // unit geometric normals
  // Mip pyramids of the textures (level 0 = the texture), and per triangle the texture's
  // resolution on the surface (texels per metre, from the uv-to-world area ratio) so that each
  // pixel samples the level whose texels match its footprint: no aliasing of far surfaces and
  // far fewer cache misses. Every level of every texture lives in `texels` (RGB, rows of width * 3
  // bytes) at level_offset; texture t's levels are texture_first_level[t] + 0 .. count - 1. Four
  // bytes of padding let a 4-byte load at the last texel stay inside (the AVX2 pass's gathers).
  std::vector<std::uint8_t> texels;
  std::vector<std::size_t> level_offset;
  std::vector<std::int32_t> level_width, level_height;
  std::vector<std::int32_t> texture_first_level, texture_level_count;
  std::vector<float> triangle_texels_per_metre;
  // For render_rows' AVX2 albedo pass, which gathers eight pixels' surface data at a time: per
  // triangle its material's texture (-1: none) and albedo (r, g, b, unused), and the levels' offsets
  // as 32-bit gather indices. Empty where albedo_at has to do it: vertex colours, or texels or
  // triangles beyond 32-bit indices.
  std::vector<std::int32_t> triangle_texture;
  std::vector<float> triangle_albedo;
  std::vector<std::int32_t> level_offset32;
  // The lights as structure of arrays padded to whole batches, so that the per-pixel light loop
  // computes a batch of lights in SIMD lanes instead of one sqrt and one division after the other
  // (the loop was half of the shading time). Padding lights have intensity 0 and are never summed.
  static constexpr int kLightBatch = 4;  // one SSE register
  static constexpr float kAmbient = 0.35f;
  std::vector<float> light_x, light_y, light_z, light_intensity;

  explicit Impl(const Scene& s) : scene(s) {}
  ~Impl() {
    if (rtc_scene) rtcReleaseScene(rtc_scene);
    if (device) rtcReleaseDevice(device);
  }

  Eigen::Vector3f sample_texture(int level, float u, float v) const {
    // Bilinear with wrap-around ("repeat"); row 0 is v = 1 (top). Wrapping the coordinate
    // first keeps integer division out of the per-pixel path.
    struct {
      int width, height;
      const std::uint8_t* rgb;
    } texture{level_width[level], level_height[level], texels.data() + level_offset[level]};
    const float wrapped_u = u - std::floor(u);
    const float wrapped_v = (1.0f - v) - std::floor(1.0f - v);
    const float sx = wrapped_u * texture.width - 0.5f;
    const float sy = wrapped_v * texture.height - 0.5f;
    int x0 = static_cast<int>(std::floor(sx)), y0 = static_cast<int>(std::floor(sy));
    const float ax = sx - x0, ay = sy - y0;
    int x1 = x0 + 1, y1 = y0 + 1;
    if (x0 < 0) x0 += texture.width;
    if (y0 < 0) y0 += texture.height;
    if (x1 >= texture.width) x1 -= texture.width;
    if (y1 >= texture.height) y1 -= texture.height;
    x0 = std::min(x0, texture.width - 1);  // guards rounding at wrapped_u -> 1
    y0 = std::min(y0, texture.height - 1);
#if defined(__SSE2__)
    // The three channels in SSE lanes (the fourth is unused): per lane the float operations of the
    // Eigen expression below, in its order, so the colour is the same.
    auto texel = [&](int x, int y) {
      const std::uint8_t* p = &texture.rgb[(std::size_t(y) * texture.width + x) * 3];
      const __m128i bytes =
          _mm_cvtsi32_si128(int(std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16));
      const __m128i zero = _mm_setzero_si128();
      return _mm_cvtepi32_ps(_mm_unpacklo_epi16(_mm_unpacklo_epi8(bytes, zero), zero));
    };
    const __m128 weight_x0 = _mm_set1_ps(1 - ax), weight_x1 = _mm_set1_ps(ax);
    const __m128 top = _mm_add_ps(_mm_mul_ps(weight_x0, texel(x0, y0)), _mm_mul_ps(weight_x1, texel(x1, y0)));
    const __m128 bottom = _mm_add_ps(_mm_mul_ps(weight_x0, texel(x0, y1)), _mm_mul_ps(weight_x1, texel(x1, y1)));
    const __m128 blended =
        _mm_mul_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(1 - ay), top), _mm_mul_ps(_mm_set1_ps(ay), bottom)),
                   _mm_set1_ps(1.0f / 255.0f));
    alignas(16) float lanes[4];
    _mm_store_ps(lanes, blended);
    return Eigen::Vector3f(lanes[0], lanes[1], lanes[2]);
#else
    auto texel = [&](int x, int y) {
      const std::uint8_t* p = &texture.rgb[(std::size_t(y) * texture.width + x) * 3];
      return Eigen::Vector3f(p[0], p[1], p[2]);
    };
    return ((1 - ay) * ((1 - ax) * texel(x0, y0) + ax * texel(x1, y0)) +
            ay * ((1 - ax) * texel(x0, y1) + ax * texel(x1, y1))) *
           (1.0f / 255.0f);
#endif
  }

  // Simple, view-independent shading: ambient + Lambert from the scene's point lights, no
  // shadows (consistent colour across views, which is what a registered RGB camera sees of a
  // matte static scene).
  // The index of the mip level (into level_offset, ...) for a pixel of `triangle`.
  int mip_level(int texture, unsigned triangle, float pixel_footprint_m) const {
    const float texels_per_pixel = pixel_footprint_m * triangle_texels_per_metre[triangle];
    // floor(log2) from the exponent bits: what std::ilogb returns for the values >= 2 taken here
    // (all normal; +inf gives 128, clamped below as ilogb's INT_MAX is), without its libm call per pixel.
    int level = 0;
    if (texels_per_pixel >= 2.f) {
      std::uint32_t bits;
      std::memcpy(&bits, &texels_per_pixel, sizeof bits);
      level = int((bits >> 23) & 0xffu) - 127;
    }
    return texture_first_level[texture] + std::min<int>(level, texture_level_count[texture] - 1);
  }

  void build_albedo_lanes() {
    const TriangleMesh& mesh = scene.mesh;
    const std::size_t triangles = mesh.triangles.size();
    if (!mesh.vertex_colours.empty() || texels.size() >= std::size_t(INT32_MAX) ||
        triangles >= std::size_t(INT32_MAX) / 6)
      return;
    triangle_texture.assign(triangles, -1);
    triangle_albedo.assign(4 * triangles, 0.8f);
    if (!mesh.triangle_material.empty())
      for (std::size_t t = 0; t < triangles; ++t) {
        const Material& material = scene.materials[mesh.triangle_material[t]];
        for (int c = 0; c < 3; ++c) triangle_albedo[4 * t + c] = material.albedo[c];
        if (material.texture >= 0 && !mesh.corner_uvs.empty()) triangle_texture[t] = material.texture;
      }
    level_offset32.assign(level_offset.begin(), level_offset.end());
  }

  void build_light_batches() {
    const std::size_t padded = (scene.lights.size() + kLightBatch - 1) / kLightBatch * kLightBatch;
    light_x.assign(padded, 0.f);
    light_y.assign(padded, 0.f);
    light_z.assign(padded, 0.f);
    light_intensity.assign(padded, 0.f);
    for (std::size_t i = 0; i < scene.lights.size(); ++i) {
      light_x[i] = scene.lights[i].position.x();
      light_y[i] = scene.lights[i].position.y();
      light_z[i] = scene.lights[i].position.z();
      light_intensity[i] = scene.lights[i].intensity;
    }
  }

  void build_mip_levels() {
    // Reserve the whole pyramid first: growing the array level by level copied it over and over.
    std::size_t total = 4;
    for (const Texture& texture : scene.textures)
      for (int width = texture.width, height = texture.height;;
           width = std::max(1, width / 2), height = std::max(1, height / 2)) {
        total += std::size_t(width) * height * 3;
        if (width <= 1 || height <= 1) break;
      }
    texels.reserve(total);
    for (const Texture& texture : scene.textures) {
      texture_first_level.push_back(std::int32_t(level_width.size()));
      std::vector<std::uint8_t> fine = texture.rgb;
      int fine_width = texture.width, fine_height = texture.height;
      for (;;) {
        level_offset.push_back(texels.size());
        level_width.push_back(fine_width);
        level_height.push_back(fine_height);
        texels.insert(texels.end(), fine.begin(), fine.end());
        if (fine_width <= 1 || fine_height <= 1) break;
        const int width = std::max(1, fine_width / 2), height = std::max(1, fine_height / 2);
        std::vector<std::uint8_t> coarse(std::size_t(width) * height * 3);
        for (int y = 0; y < height; ++y)
          for (int x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c) {
              // 2x2 box filter (the last odd row/column of the finer level is dropped).
              int sum = 0;
              for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx)
                  sum += fine[((std::size_t(2 * y + dy)) * fine_width + (2 * x + dx)) * 3 + c];
              coarse[(std::size_t(y) * width + x) * 3 + c] = static_cast<std::uint8_t>((sum + 2) / 4);
            }
        fine = std::move(coarse);
        fine_width = width;
        fine_height = height;
      }
      texture_level_count.push_back(std::int32_t(level_width.size()) - texture_first_level.back());
    }
    texels.resize(texels.size() + 4, 0);
    const TriangleMesh& mesh = scene.mesh;
    triangle_texels_per_metre.assign(mesh.triangles.size(), 0.f);
    if (mesh.corner_uvs.empty() || mesh.triangle_material.empty()) return;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const int texture = scene.materials[mesh.triangle_material[t]].texture;
      if (texture < 0) continue;
      const Eigen::Vector3i& tri = mesh.triangles[t];
      const float world_area =
          0.5f *
          (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]).norm();
      const Eigen::Vector2f e1 = mesh.corner_uvs[3 * t + 1] - mesh.corner_uvs[3 * t];
      const Eigen::Vector2f e2 = mesh.corner_uvs[3 * t + 2] - mesh.corner_uvs[3 * t];
      const float texel_area = 0.5f * std::abs(e1.x() * e2.y() - e1.y() * e2.x()) * scene.textures[texture].width *
                               scene.textures[texture].height;
      if (world_area > 0) triangle_texels_per_metre[t] = std::sqrt(texel_area / world_area);
    }
  }

  // The surface colour before lighting: vertex colour, material albedo and texture (mip level by
  // `pixel_footprint_m`, the width of the surface patch one pixel sees, in metres).
  __attribute__((always_inline)) Eigen::Vector3f albedo_at(unsigned triangle, float bu, float bv,
                                                           float pixel_footprint_m) const {
    const TriangleMesh& mesh = scene.mesh;
    Eigen::Vector3f albedo(0.8f, 0.8f, 0.8f);
    const bool vertex_coloured = !mesh.vertex_colours.empty();
    if (vertex_coloured) {
      // Per-vertex colour, interpolated with the hit's barycentrics, is the base colour.
      const Eigen::Vector3i& tri = mesh.triangles[triangle];
      albedo = (1 - bu - bv) * mesh.vertex_colours[tri[0]] + bu * mesh.vertex_colours[tri[1]] +
               bv * mesh.vertex_colours[tri[2]];
    }
    if (!mesh.triangle_material.empty()) {
      const Material& material = scene.materials[mesh.triangle_material[triangle]];
      if (!vertex_coloured) albedo = material.albedo;
      if (material.texture >= 0 && !mesh.corner_uvs.empty()) {
        const Eigen::Vector2f uv = (1 - bu - bv) * mesh.corner_uvs[3 * triangle] +
                                   bu * mesh.corner_uvs[3 * triangle + 1] + bv * mesh.corner_uvs[3 * triangle + 2];
        albedo = albedo.cwiseProduct(
            sample_texture(mip_level(material.texture, triangle, pixel_footprint_m), uv.x(), uv.y()));
      }
    }
    return albedo;
  }

  // One pixel's colour: the reference for the row-wise shading of render_rows, which computes the
  // same float operations in the same order several pixels at a time (row_geometry, row_diffuse,
  // row_colour), and of the panorama renderer.
  Eigen::Vector3f shade(unsigned triangle, float bu, float bv, const Eigen::Vector3f& point,
                        const Eigen::Vector3f& ray_dir, float pixel_footprint_m) const {
    const Eigen::Vector3f albedo = albedo_at(triangle, bu, bv, pixel_footprint_m);
    Eigen::Vector3f normal = triangle_normals[triangle];
    if (normal.dot(ray_dir) > 0) normal = -normal;
    float diffuse = 0.f;
    if (scene.lights.empty()) {
      diffuse = std::abs(normal.dot(ray_dir.normalized()));  // headlight fallback
    } else {
      // The same float operations in the same order as Eigen's per-light
      // `normal.dot(light.position - point)` and `squaredNorm()` (x + (y + z), Eigen's unrolled
      // sum), so the colour is bit-identical to the one-light-at-a-time loop; a light behind the
      // surface adds nothing, as the loop skipped it, and adding +0 leaves the sum as it was.
      const std::size_t count = scene.lights.size();
      for (std::size_t batch = 0; batch < count; batch += kLightBatch) {
        alignas(16) float contribution[kLightBatch];
#if defined(__SSE2__)
        // SSE by hand: GCC does not vectorise std::sqrt without -fno-math-errno. sqrtps and divps
        // round each lane exactly as sqrtss and divss do.
        const __m128 tx = _mm_sub_ps(_mm_loadu_ps(&light_x[batch]), _mm_set1_ps(point.x()));
        const __m128 ty = _mm_sub_ps(_mm_loadu_ps(&light_y[batch]), _mm_set1_ps(point.y()));
        const __m128 tz = _mm_sub_ps(_mm_loadu_ps(&light_z[batch]), _mm_set1_ps(point.z()));
        const __m128 facing =
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(normal.x()), tx),
                       _mm_add_ps(_mm_mul_ps(_mm_set1_ps(normal.y()), ty), _mm_mul_ps(_mm_set1_ps(normal.z()), tz)));
        const __m128 d2 = _mm_max_ps(_mm_add_ps(_mm_mul_ps(tx, tx), _mm_add_ps(_mm_mul_ps(ty, ty), _mm_mul_ps(tz, tz))),
                                     _mm_set1_ps(1e-8f));
        const __m128 numerator =
            _mm_mul_ps(_mm_mul_ps(_mm_loadu_ps(&light_intensity[batch]), facing), _mm_set1_ps(2.f));
        const __m128 denominator =
            _mm_mul_ps(_mm_sqrt_ps(d2), _mm_add_ps(_mm_set1_ps(1.f), _mm_mul_ps(_mm_set1_ps(0.25f), d2)));
        const __m128 value = _mm_div_ps(numerator, denominator);
        _mm_store_ps(contribution, _mm_and_ps(value, _mm_cmpgt_ps(facing, _mm_setzero_ps())));
#else
        for (int i = 0; i < kLightBatch; ++i) {
          const float tx = light_x[batch + i] - point.x();
          const float ty = light_y[batch + i] - point.y();
          const float tz = light_z[batch + i] - point.z();
          const float facing = normal.x() * tx + (normal.y() * ty + normal.z() * tz);
          const float d2 = std::max(tx * tx + (ty * ty + tz * tz), 1e-8f);
          const float value = light_intensity[batch + i] * facing * 2.f / (std::sqrt(d2) * (1.f + 0.25f * d2));
          contribution[i] = facing > 0.f ? value : 0.f;
        }
#endif
        for (std::size_t i = 0; i < std::size_t(kLightBatch) && batch + i < count; ++i) diffuse += contribution[i];
      }
      diffuse = std::min(diffuse / float(scene.lights.size()), 1.2f);
    }
    return albedo * (kAmbient + (1.f - kAmbient) * diffuse);
  }
};

Renderer::Renderer(const Scene& scene) : impl_(std::make_unique<Impl>(scene)) {
  scene.check("<scene " + scene.name + ">");
  impl_->device = rtcNewDevice(cpu::embree_device_config().c_str());
  if (!impl_->device)
    throw Error("Embree: cannot create a device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
  impl_->rtc_scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->rtc_scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  const auto& mesh = scene.mesh;
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = mesh.vertices[i][k];
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), mesh.triangles.size()));
  impl_->triangle_normals.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) indices[3 * t + k] = static_cast<unsigned>(tri[k]);
    const Eigen::Vector3f n =
        (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
    impl_->triangle_normals[t] = n.norm() > 0 ? Eigen::Vector3f(n.normalized()) : Eigen::Vector3f::UnitZ();
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->rtc_scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->rtc_scene);
  impl_->build_mip_levels();
  impl_->build_albedo_lanes();
  impl_->build_light_batches();
  const RTCError error = rtcGetDeviceError(impl_->device);
  if (error != RTC_ERROR_NONE) throw Error("Embree: scene build failed (error " + std::to_string(int(error)) + ")");
}

Renderer::~Renderer() = default;

namespace {

// A view's images, `filled` with the values of "nothing hit" (depth, incidence, colour and normals
// 0, triangle -1), or else left uninitialised for a caller that renders every row: render_rows
// copies every pixel of depth, incidence and (if requested) triangle ids and normals, and of the colour
// unless the request has none (then it stays black, so it is filled either way). The zero fill was a
// pass over 5 MB per 640x480 frame.
RenderedView make_view(const PinholeIntrinsics& k, const RenderRequest& request, bool filled) {
  const auto image = [&](auto type, int channels, auto nothing) {
    using ImageT = decltype(type);
    return filled ? ImageT(k.width, k.height, channels, nothing) : ImageT::uninitialised(k.width, k.height, channels);
  };
  RenderedView view;
  view.depth = image(ImageF32{}, 1, 0.f);
  view.rgb =
      filled || !request.colour ? ImageU8(k.width, k.height, 3, 0) : ImageU8::uninitialised(k.width, k.height, 3);
  view.incidence_cos = image(ImageF32{}, 1, 0.f);
  if (request.triangle_ids) view.triangle_id = image(ImageI32{}, 1, -1);
  if (request.normals) view.normal_cam = image(ImageF32{}, 3, 0.f);
  return view;
}

}  // namespace

RenderedView Renderer::allocate(const PinholeIntrinsics& k, const RenderRequest& request) {
  return make_view(k, request, true);
}

namespace {

// Ray through pixel (u, v) with a direction whose camera-z component is 1, so the hit
// distance t is the z-depth itself.
inline void setup_ray(RTCRayHit& ray_hit, const Eigen::Vector3f& origin, const Eigen::Vector3f& direction) {
  ray_hit.ray.org_x = origin.x();
  ray_hit.ray.org_y = origin.y();
  ray_hit.ray.org_z = origin.z();
  ray_hit.ray.dir_x = direction.x();
  ray_hit.ray.dir_y = direction.y();
  ray_hit.ray.dir_z = direction.z();
  ray_hit.ray.tnear = 0.f;
  ray_hit.ray.tfar = std::numeric_limits<float>::infinity();
  ray_hit.ray.time = 0.f;
  ray_hit.ray.mask = 0xFFFFFFFFu;  // Debian's Embree has ray masks on: mask 0 hits nothing
  ray_hit.ray.id = 0;
  ray_hit.ray.flags = 0;
  ray_hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  ray_hit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

namespace {

// Primary rays are traced in packets of N neighbouring pixels of a row. Measured by process CPU
// time per 640x480 view of the bare intersection (benchmarks/render_benchmark): 8-ray rows 6.4 ms,
// 4 x 2 tiles 6.6 ms; 16-ray rows 5.3-5.6 ms, 8 x 2 and 4 x 4 tiles 5.5-5.7 ms. The rays of any of
// these span a few pixels and visit nearly the same BVH nodes, so the packet width is what counts:
// the renderer uses 16 (one AVX-512 register per component where the CPU has it; Embree splits it
// where not), the 8-ray loop stays as the speed report's reference.
template <typename PacketRayHit>
constexpr int lanes_of() {
  return std::is_same_v<PacketRayHit, RTCRayHit16> ? 16 : 8;
}
constexpr int kRenderLanes = 16;
using RenderPacket = RTCRayHit16;

inline void intersect_packet(const int* valid, RTCScene scene, RTCIntersectContext* context, RTCRayHit8* packet) {
  rtcIntersect8(valid, scene, context, packet);
}
inline void intersect_packet(const int* valid, RTCScene scene, RTCIntersectContext* context, RTCRayHit16* packet) {
  rtcIntersect16(valid, scene, context, packet);
}

// A packet of N neighbouring pixels of a row, its constant fields (origin, tnear, mask, ...) set
// once per view. Directions have camera-z component 1, so the hit distance is the z-depth:
// d = R (a, b, 1) with a = (x - cx) / fx per column and b = (y - cy) / fy per row, component i
// evaluated as R(i,0) a + (R(i,1) b + R(i,2)), the order of Eigen's `rotation * Vector3f(a, b, 1)`,
// so the rays are bit for bit the ones of the per-lane product this replaced (which, with all
// fields written per lane, was a fifth of the rays stage).
template <typename PacketRayHit>
class PacketRow {
 public:
  static constexpr int kLanes = lanes_of<PacketRayHit>();

  PacketRow(const Rigid3d& world_from_cam, const PinholeIntrinsics& k)
      : k_(k), rotation_(world_from_cam.linear().cast<float>()) {
    const Eigen::Vector3f origin = world_from_cam.translation().cast<float>();
    const int padded = (k.width + kLanes - 1) / kLanes * kLanes;
    column_.resize(padded);
    // Lanes past the row end repeat the last column (and are invalid).
    for (int x = 0; x < padded; ++x) column_[x] = float((std::min(x, k.width - 1) - k.cx) / k.fx);
    for (int lane = 0; lane < kLanes; ++lane) {
      packet_.ray.org_x[lane] = origin.x();
      packet_.ray.org_y[lane] = origin.y();
      packet_.ray.org_z[lane] = origin.z();
      packet_.ray.tnear[lane] = 0.f;
      packet_.ray.time[lane] = 0.f;
      packet_.ray.mask[lane] = 0xFFFFFFFFu;  // Debian's Embree has ray masks on: mask 0 hits nothing
      packet_.ray.id[lane] = 0;
      packet_.ray.flags[lane] = 0;
    }
  }

  void start_row(int y) {
    const float b = float((y - k_.cy) / k_.fy);
    for (int i = 0; i < 3; ++i) row_term_[i] = rotation_(i, 1) * b + rotation_(i, 2);
  }

  // Traces pixels (x0 .. x0 + N - 1) of the row; lanes past the row end are invalid and miss.
  void trace(RTCScene scene, RTCIntersectContext* context, int x0) {
    const float* a = &column_[x0];
    const float r00 = rotation_(0, 0), r10 = rotation_(1, 0), r20 = rotation_(2, 0);
    for (int lane = 0; lane < kLanes; ++lane) {
      valid_[lane] = x0 + lane < k_.width ? -1 : 0;
      packet_.ray.dir_x[lane] = r00 * a[lane] + row_term_[0];
      packet_.ray.dir_y[lane] = r10 * a[lane] + row_term_[1];
      packet_.ray.dir_z[lane] = r20 * a[lane] + row_term_[2];
      packet_.ray.tfar[lane] = std::numeric_limits<float>::infinity();
      packet_.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
      packet_.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
    }
    intersect_packet(valid_, scene, context, &packet_);
  }

  const PacketRayHit& packet() const { return packet_; }
  bool valid(int lane) const { return valid_[lane] != 0; }

 private:
  alignas(64) PacketRayHit packet_;
  alignas(64) int valid_[kLanes];
  const PinholeIntrinsics& k_;
  Eigen::Matrix3f rotation_;
  std::vector<float> column_;
  float row_term_[3] = {0.f, 0.f, 0.f};
};

using render_rows::LightArrays;
using render_rows::RowScratch;

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

namespace {

#if defined(__x86_64__) && defined(__GNUC__)
#define PANOSCAN_RENDER_AVX 1
#endif

#if PANOSCAN_RENDER_AVX

// The hit triangles' unit normals (`normals`: x, y, z per triangle), +z for a miss, eight pixels
// per AVX2 gather, or one load where the eight share a triangle.
__attribute__((target("avx2"))) void row_normals_avx2(RowScratch& row, int padded_width, const float* normals) {
  for (int x = 0; x < padded_width; x += 8) {
    const __m256i hit = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(&row.hit[x]));
    const __m256i triangle =
        _mm256_and_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&row.triangle[x])), hit);
    const unsigned first = row.triangle[x];
    __m256 n[3];
    if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(triangle, _mm256_set1_epi32(int(first)))) == -1 &&
        _mm256_movemask_epi8(hit) == -1) {
      for (int c = 0; c < 3; ++c) n[c] = _mm256_set1_ps(normals[3 * std::size_t(first) + c]);
    } else {
      const __m256i index = _mm256_mullo_epi32(triangle, _mm256_set1_epi32(3));
      for (int c = 0; c < 3; ++c) n[c] = _mm256_i32gather_ps(normals + c, index, 4);
      const __m256 miss = _mm256_castsi256_ps(_mm256_cmpeq_epi32(hit, _mm256_setzero_si256()));
      n[0] = _mm256_andnot_ps(miss, n[0]);
      n[1] = _mm256_andnot_ps(miss, n[1]);
      n[2] = _mm256_blendv_ps(n[2], _mm256_set1_ps(1.f), miss);
    }
    _mm256_storeu_ps(&row.normal_x[x], n[0]);
    _mm256_storeu_ps(&row.normal_y[x], n[1]);
    _mm256_storeu_ps(&row.normal_z[x], n[2]);
  }
}
#endif

// The per-pixel geometry of a traced row (row_lanes.h), eight pixels per AVX operation where the CPU
// has AVX, else four per SSE operation.
void row_geometry(RowScratch& row, int padded_width, const Eigen::Vector3f& origin, float inv_fx) {
#if PANOSCAN_ROW_LANES_AVX
  if (padded_width % 8 == 0 && cpu::has_avx()) {
    render_rows::row_geometry_avx(row, padded_width, origin, inv_fx);
    return;
  }
#endif
#if defined(__SSE2__)
  render_rows::row_geometry_lanes<render_rows::SseLanes>(row, padded_width, origin, inv_fx);
#else
  render_rows::row_geometry_lanes<render_rows::ScalarLanes>(row, padded_width, origin, inv_fx);
#endif
}

// Lambert from the point lights (row_lanes.h), eight pixels per AVX operation where the CPU has AVX,
// else four per SSE operation.
void row_diffuse(RowScratch& row, int padded_width, const LightArrays& lights) {
#if PANOSCAN_ROW_LANES_AVX
  if (padded_width % 8 == 0 && cpu::has_avx()) {
    render_rows::row_diffuse_avx(row, padded_width, lights);
    return;
  }
#endif
#if defined(__SSE2__)
  render_rows::row_diffuse_lanes<render_rows::SseLanes>(row, padded_width, lights);
#else
  render_rows::row_diffuse_lanes<render_rows::ScalarLanes>(row, padded_width, lights);
#endif
}

#if PANOSCAN_RENDER_AVX
// What row_albedo_avx2 reads: Renderer::Impl's per-triangle and per-level tables.
struct AlbedoLanes {
  const std::int32_t* triangle_texture;  // -1: untextured
  const float* triangle_albedo;          // 4 per triangle
  const float* corner_uvs;               // 6 per triangle: u, v of each corner
  const float* texels_per_metre;         // per triangle
  const std::int32_t* texture_first_level;
  const std::int32_t* texture_level_count;
  const std::int32_t* level_offset;
  const std::int32_t* level_width;
  const std::int32_t* level_height;
  const std::uint8_t* texels;  // padded: a 4-byte load at the last texel stays inside
};

// Renderer::Impl::albedo_at for eight pixels per AVX2 operation (meshes without vertex colours):
// the material's albedo, times the bilinear texel of the pixel's mip level where the material has a
// texture; 0 where nothing was hit. The per-pixel path fetched each texel's three bytes and chose
// its level and wrap with branches, and was half of the shading time. Per lane the same float
// operations in the same order (no FMA; vroundps is floorf), so the colour is the same bit for bit.
__attribute__((target("avx2"))) void row_albedo_avx2(RowScratch& row, int padded_width, const AlbedoLanes& in) {
  const __m256 one = _mm256_set1_ps(1.f), half = _mm256_set1_ps(0.5f);
  const __m256i one_i = _mm256_set1_epi32(1), three_i = _mm256_set1_epi32(3), byte = _mm256_set1_epi32(0xff);
  const auto* texel_words = reinterpret_cast<const int*>(in.texels);
  for (int x = 0; x < padded_width; x += 8) {
    const __m256i hit = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(&row.hit[x]));
    // Misses gather triangle 0's entries, which are then discarded.
    const __m256i triangle =
        _mm256_and_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&row.triangle[x])), hit);
    // Most blocks lie on one triangle (walls, floors, table tops): its entries are then loaded once
    // and broadcast instead of gathered per lane, as are the level's where all lanes share it.
    const unsigned first_triangle = row.triangle[x];
    const bool one_triangle =
        _mm256_movemask_epi8(_mm256_cmpeq_epi32(triangle, _mm256_set1_epi32(int(first_triangle)))) == -1 &&
        _mm256_movemask_epi8(hit) == -1;
    __m256 albedo[3];
    __m256i texture;
    if (one_triangle) {
      for (int c = 0; c < 3; ++c) albedo[c] = _mm256_set1_ps(in.triangle_albedo[4 * std::size_t(first_triangle) + c]);
      texture = _mm256_set1_epi32(in.triangle_texture[first_triangle]);
    } else {
      const __m256i albedo_index = _mm256_slli_epi32(triangle, 2);
      for (int c = 0; c < 3; ++c)
        albedo[c] = _mm256_i32gather_ps(in.triangle_albedo, _mm256_add_epi32(albedo_index, _mm256_set1_epi32(c)), 4);
      texture = _mm256_i32gather_epi32(in.triangle_texture, triangle, 4);
    }
    const __m256i textured = _mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), texture), hit);
    if (!_mm256_testz_si256(textured, textured)) {
      // uv = (1 - bu - bv) uv0 + bu uv1 + bv uv2, summed left to right as Eigen does.
      const __m256 bu = _mm256_loadu_ps(&row.u[x]), bv = _mm256_loadu_ps(&row.v[x]);
      const __m256 w0 = _mm256_sub_ps(_mm256_sub_ps(one, bu), bv);
      __m256 corner[6];
      __m256 texels_per_metre;
      if (one_triangle) {
        for (int k = 0; k < 6; ++k) corner[k] = _mm256_set1_ps(in.corner_uvs[6 * std::size_t(first_triangle) + k]);
        texels_per_metre = _mm256_set1_ps(in.texels_per_metre[first_triangle]);
      } else {
        const __m256i uv_index = _mm256_mullo_epi32(triangle, _mm256_set1_epi32(6));
        for (int k = 0; k < 6; ++k)
          corner[k] = _mm256_i32gather_ps(in.corner_uvs, _mm256_add_epi32(uv_index, _mm256_set1_epi32(k)), 4);
        texels_per_metre = _mm256_i32gather_ps(in.texels_per_metre, triangle, 4);
      }
      const __m256 u = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, corner[0]), _mm256_mul_ps(bu, corner[2])),
                                     _mm256_mul_ps(bv, corner[4]));
      const __m256 v = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, corner[1]), _mm256_mul_ps(bu, corner[3])),
                                     _mm256_mul_ps(bv, corner[5]));
      // mip_level: floor(log2(texels per pixel)) from the exponent bits where it is >= 2, else 0,
      // capped at the texture's coarsest level.
      const __m256 texels_per_pixel = _mm256_mul_ps(_mm256_loadu_ps(&row.footprint[x]), texels_per_metre);
      const __m256i exponent = _mm256_sub_epi32(
          _mm256_and_si256(_mm256_srli_epi32(_mm256_castps_si256(texels_per_pixel), 23), byte), _mm256_set1_epi32(127));
      const __m256i finer_levels = _mm256_and_si256(
          exponent, _mm256_castps_si256(_mm256_cmp_ps(texels_per_pixel, _mm256_set1_ps(2.f), _CMP_GE_OQ)));
      __m256i level;
      if (one_triangle) {
        const int t = in.triangle_texture[first_triangle];
        level = _mm256_add_epi32(_mm256_set1_epi32(in.texture_first_level[t]),
                                 _mm256_min_epi32(finer_levels, _mm256_set1_epi32(in.texture_level_count[t] - 1)));
      } else {
        const __m256i safe_texture = _mm256_and_si256(texture, textured);
        level = _mm256_add_epi32(
            _mm256_i32gather_epi32(in.texture_first_level, safe_texture, 4),
            _mm256_min_epi32(finer_levels,
                             _mm256_sub_epi32(_mm256_i32gather_epi32(in.texture_level_count, safe_texture, 4), one_i)));
      }
      __m256i width, height, offset;
      const int first_level = _mm256_cvtsi256_si32(level);
      if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(level, _mm256_set1_epi32(first_level))) == -1) {
        width = _mm256_set1_epi32(in.level_width[first_level]);
        height = _mm256_set1_epi32(in.level_height[first_level]);
        offset = _mm256_set1_epi32(in.level_offset[first_level]);
      } else {
        width = _mm256_i32gather_epi32(in.level_width, level, 4);
        height = _mm256_i32gather_epi32(in.level_height, level, 4);
        offset = _mm256_i32gather_epi32(in.level_offset, level, 4);
      }
      // sample_texture: wrap, then the four texels around the sample point.
      const __m256 wrapped_u = _mm256_sub_ps(u, _mm256_floor_ps(u));
      const __m256 flipped_v = _mm256_sub_ps(one, v);
      const __m256 wrapped_v = _mm256_sub_ps(flipped_v, _mm256_floor_ps(flipped_v));
      const __m256 sx = _mm256_sub_ps(_mm256_mul_ps(wrapped_u, _mm256_cvtepi32_ps(width)), half);
      const __m256 sy = _mm256_sub_ps(_mm256_mul_ps(wrapped_v, _mm256_cvtepi32_ps(height)), half);
      __m256i x0 = _mm256_cvttps_epi32(_mm256_floor_ps(sx)), y0 = _mm256_cvttps_epi32(_mm256_floor_ps(sy));
      const __m256 ax = _mm256_sub_ps(sx, _mm256_cvtepi32_ps(x0)), ay = _mm256_sub_ps(sy, _mm256_cvtepi32_ps(y0));
      __m256i x1 = _mm256_add_epi32(x0, one_i), y1 = _mm256_add_epi32(y0, one_i);
      const __m256i last_x = _mm256_sub_epi32(width, one_i), last_y = _mm256_sub_epi32(height, one_i);
      x0 = _mm256_add_epi32(x0, _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), x0), width));
      y0 = _mm256_add_epi32(y0, _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), y0), height));
      x1 = _mm256_sub_epi32(x1, _mm256_and_si256(_mm256_cmpgt_epi32(x1, last_x), width));
      y1 = _mm256_sub_epi32(y1, _mm256_and_si256(_mm256_cmpgt_epi32(y1, last_y), height));
      x0 = _mm256_min_epi32(x0, last_x);
      y0 = _mm256_min_epi32(y0, last_y);
      const __m256i row0 = _mm256_mullo_epi32(y0, width), row1 = _mm256_mullo_epi32(y1, width);
      // Four bytes from each texel's first: its R, G, B and a byte that is ignored. Order: (x0, y0),
      // (x1, y0), (x0, y1), (x1, y1).
      const __m256i texel_index[4] = {_mm256_add_epi32(row0, x0), _mm256_add_epi32(row0, x1),
                                      _mm256_add_epi32(row1, x0), _mm256_add_epi32(row1, x1)};
      __m256i texel[4];
      for (int k = 0; k < 4; ++k)
        texel[k] = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), texel_words,
                                               _mm256_add_epi32(offset, _mm256_mullo_epi32(texel_index[k], three_i)),
                                               textured, 1);
      const __m256 wx0 = _mm256_sub_ps(one, ax), wy0 = _mm256_sub_ps(one, ay);
      for (int c = 0; c < 3; ++c) {
        __m256 channel[4];
        for (int k = 0; k < 4; ++k)
          channel[k] = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(texel[k], 8 * c), byte));
        const __m256 top = _mm256_add_ps(_mm256_mul_ps(wx0, channel[0]), _mm256_mul_ps(ax, channel[1]));
        const __m256 bottom = _mm256_add_ps(_mm256_mul_ps(wx0, channel[2]), _mm256_mul_ps(ax, channel[3]));
        const __m256 blended = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(wy0, top), _mm256_mul_ps(ay, bottom)),
                                             _mm256_set1_ps(1.0f / 255.0f));
        albedo[c] = _mm256_blendv_ps(albedo[c], _mm256_mul_ps(albedo[c], blended), _mm256_castsi256_ps(textured));
      }
    }
    _mm256_storeu_ps(&row.albedo_r[x], _mm256_and_ps(albedo[0], _mm256_castsi256_ps(hit)));
    _mm256_storeu_ps(&row.albedo_g[x], _mm256_and_ps(albedo[1], _mm256_castsi256_ps(hit)));
    _mm256_storeu_ps(&row.albedo_b[x], _mm256_and_ps(albedo[2], _mm256_castsi256_ps(hit)));
  }
}
#endif

// albedo * (ambient + (1 - ambient) * diffuse) to 8 bits, rounded and clamped as shade's callers do;
// 0 where nothing was hit.
void row_colour(RowScratch& row, int padded_width, float ambient) {
  const std::size_t plane = std::size_t(padded_width);
#if defined(__SSE2__)
  for (int x = 0; x < padded_width; x += 4) {
    const __m128 light =
        _mm_add_ps(_mm_set1_ps(ambient), _mm_mul_ps(_mm_set1_ps(1.f - ambient), _mm_loadu_ps(&row.diffuse[x])));
    const __m128i hit = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&row.hit[x]));
    const float* albedo[3] = {&row.albedo_r[x], &row.albedo_g[x], &row.albedo_b[x]};
    for (int c = 0; c < 3; ++c) {
      const __m128 scaled =
          _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_loadu_ps(albedo[c]), light), _mm_set1_ps(255.f)), _mm_set1_ps(0.5f));
      const __m128 clamped = _mm_min_ps(_mm_max_ps(scaled, _mm_setzero_ps()), _mm_set1_ps(255.f));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(&row.rgb[c * plane + x]),
                       _mm_and_si128(_mm_cvttps_epi32(clamped), hit));
    }
  }
#else
  for (int x = 0; x < padded_width; ++x) {
    const float light = ambient + (1.f - ambient) * row.diffuse[x];
    const float albedo[3] = {row.albedo_r[x], row.albedo_g[x], row.albedo_b[x]};
    for (int c = 0; c < 3; ++c)
      row.rgb[c * plane + x] = row.hit[x] ? int(std::clamp(albedo[c] * light * 255.f + 0.5f, 0.f, 255.f)) : 0;
  }
#endif
}

}  // namespace

void Renderer::render_rows(const Rigid3d& world_from_cam, const PinholeIntrinsics& k, int row_begin, int row_end,
                           RenderedView& out, const RenderRequest& request, RenderTimes* times) const {
  const Eigen::Matrix3f rotation = world_from_cam.linear().cast<float>();
  const Eigen::Vector3f origin = world_from_cam.translation().cast<float>();
  const Eigen::Matrix3f cam_from_world_rotation = rotation.transpose();
  if (request.normals &&
      (out.normal_cam.width != k.width || out.normal_cam.height != k.height || out.normal_cam.channels != 3))
    throw Error(
        "Renderer::render_rows: normals requested, but `out` has no normal image of the view's size "
        "(allocate it with allocate(intrinsics, request))");
  if (request.triangle_ids && (out.triangle_id.width != k.width || out.triangle_id.height != k.height))
    throw Error(
        "Renderer::render_rows: triangle ids requested, but `out` has no triangle id image of the view's size "
        "(allocate it with allocate(intrinsics, request))");
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  // Primary camera rays are coherent: packets of neighbouring pixels are Embree's fast path
  // (about 4x the single-ray throughput on the CI machine, see benchmarks/render_benchmark).
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  PacketRow<RenderPacket> rays(world_from_cam, k);
  const float inv_fx = float(1.0 / k.fx);
  const int width = k.width;
  const int padded_width = (width + kRenderLanes - 1) / kRenderLanes * kRenderLanes;
  const Impl& impl = *impl_;
  const Scene& scene = impl.scene;
  // One row at a time: all its packets first, then its shading passes, so that the BVH and the
  // textures each stay in cache for a whole pass, and the two can be timed apart.
  RowScratch row(padded_width);
#if PANOSCAN_RENDER_AVX
  const bool use_avx2 = cpu::has_avx2() && !impl.triangle_normals.empty();
  std::optional<AlbedoLanes> albedo_lanes;
  if (!impl.triangle_texture.empty() && use_avx2)
    albedo_lanes = AlbedoLanes{impl.triangle_texture.data(),
                               impl.triangle_albedo.data(),
                               scene.mesh.corner_uvs.empty() ? nullptr : scene.mesh.corner_uvs.data()->data(),
                               impl.triangle_texels_per_metre.data(),
                               impl.texture_first_level.data(),
                               impl.texture_level_count.data(),
                               impl.level_offset32.data(),
                               impl.level_width.data(),
                               impl.level_height.data(),
                               impl.texels.data()};
#endif
  std::int64_t rays_ns = 0, shading_ns = 0;
  for (int y = row_begin; y < row_end; ++y) {
    const std::int64_t start = times ? now_ns() : 0;
    rays.start_row(y);
    for (int x0 = 0; x0 < width; x0 += kRenderLanes) {
      rays.trace(impl.rtc_scene, &context, x0);
      const RenderPacket& packet = rays.packet();
      // Field by field, so that each loop is a few vector copies (one loop over all fields per lane
      // was scalar loads and stores).
      std::int32_t* hit = &row.hit[x0];
      for (int lane = 0; lane < kRenderLanes; ++lane)
        hit[lane] = packet.hit.geomID[lane] != RTC_INVALID_GEOMETRY_ID ? -1 : 0;
      for (int lane = 0; lane < kRenderLanes; ++lane) {
        // t where hit, else 0; the primitive where hit, else RTC_INVALID_GEOMETRY_ID (all ones).
        std::uint32_t t_bits;
        std::memcpy(&t_bits, &packet.ray.tfar[lane], sizeof t_bits);
        t_bits &= std::uint32_t(hit[lane]);
        std::memcpy(&row.t[x0 + lane], &t_bits, sizeof t_bits);
        row.triangle[x0 + lane] = packet.hit.primID[lane] | ~std::uint32_t(hit[lane]);
      }
      const std::size_t bytes = sizeof(float) * kRenderLanes;
      std::memcpy(&row.u[x0], packet.hit.u, bytes);
      std::memcpy(&row.v[x0], packet.hit.v, bytes);
      std::memcpy(&row.dir_x[x0], packet.ray.dir_x, bytes);
      std::memcpy(&row.dir_y[x0], packet.ray.dir_y, bytes);
      std::memcpy(&row.dir_z[x0], packet.ray.dir_z, bytes);
    }
    const std::int64_t traced_at = times ? now_ns() : 0;

#if PANOSCAN_RENDER_AVX
    if (use_avx2) {
      row_normals_avx2(row, padded_width, impl.triangle_normals.data()->data());
    } else
#endif
    {
      for (int x = 0; x < padded_width; ++x) {
        // A miss gets a placeholder normal: its lanes compute values that are then discarded.
        const Eigen::Vector3f& normal =
            row.hit[x] ? impl.triangle_normals[row.triangle[x]] : Eigen::Vector3f::UnitZ().eval();
        row.normal_x[x] = normal.x();
        row.normal_y[x] = normal.y();
        row.normal_z[x] = normal.z();
      }
    }
    row_geometry(row, padded_width, origin, inv_fx);
    std::memcpy(out.depth.row(y), row.depth.data(), sizeof(float) * width);
    std::memcpy(out.incidence_cos.row(y), row.incidence.data(), sizeof(float) * width);
    // A miss's triangle is RTC_INVALID_GEOMETRY_ID, all ones: -1 as an int32, as the image has it.
    static_assert(RTC_INVALID_GEOMETRY_ID == 0xFFFFFFFFu, "misses must read as triangle id -1");
    if (request.triangle_ids) std::memcpy(out.triangle_id.row(y), row.triangle.data(), sizeof(std::int32_t) * width);
    if (request.normals) {
      // The side the ray arrives from: a one-sided mesh seen from behind still gets a normal
      // that faces the camera, as the shading does (row_geometry turned it).
      float* normals = out.normal_cam.row(y);
      for (int x = 0; x < width; ++x) {
        const Eigen::Vector3f normal_cam =
            row.hit[x] ? Eigen::Vector3f(cam_from_world_rotation *
                                         Eigen::Vector3f(row.normal_x[x], row.normal_y[x], row.normal_z[x]))
                       : Eigen::Vector3f::Zero().eval();
        for (int c = 0; c < 3; ++c) normals[3 * x + c] = normal_cam[c];
      }
    }
    if (!request.colour) {
      if (times) {
        const std::int64_t end = now_ns();
        rays_ns += traced_at - start;
        shading_ns += end - traced_at;
      }
      continue;  // rgb stays as allocate() made it: black
    }
#if PANOSCAN_RENDER_AVX
    if (albedo_lanes) {
      row_albedo_avx2(row, padded_width, *albedo_lanes);
    } else
#endif
    {
      for (int x = 0; x < padded_width; ++x) {
        const Eigen::Vector3f albedo = row.hit[x]
                                           ? impl.albedo_at(row.triangle[x], row.u[x], row.v[x], row.footprint[x])
                                           : Eigen::Vector3f::Zero().eval();
        row.albedo_r[x] = albedo.x();
        row.albedo_g[x] = albedo.y();
        row.albedo_b[x] = albedo.z();
      }
    }
    if (!scene.lights.empty()) {
      row_diffuse(row, padded_width,
                  LightArrays{impl.light_x, impl.light_y, impl.light_z, impl.light_intensity, scene.lights.size()});
    } else {
      for (int x = 0; x < padded_width; ++x) {
        // Headlight fallback, as shade computes it.
        const Eigen::Vector3f direction(row.dir_x[x], row.dir_y[x], row.dir_z[x]);
        const Eigen::Vector3f normal(row.normal_x[x], row.normal_y[x], row.normal_z[x]);
        row.diffuse[x] = row.hit[x] ? std::abs(normal.dot(direction.normalized())) : 0.f;
      }
    }
    row_colour(row, padded_width, Impl::kAmbient);
    std::uint8_t* rgb = out.rgb.row(y);
    const std::size_t plane = std::size_t(padded_width);
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) rgb[3 * x + c] = static_cast<std::uint8_t>(row.rgb[c * plane + x]);
    if (times) {
      const std::int64_t end = now_ns();
      rays_ns += traced_at - start;
      shading_ns += end - traced_at;
    }
  }
  if (times) {
    times->rays_ns += rays_ns;
    times->shading_ns += shading_ns;
  }
}

RenderedView Renderer::render_per_pixel(const Rigid3d& world_from_cam, const PinholeIntrinsics& k,
                                        const RenderRequest& request) const {
  RenderedView out = allocate(k, request);
  const Eigen::Matrix3f rotation = world_from_cam.linear().cast<float>();
  const Eigen::Vector3f origin = world_from_cam.translation().cast<float>();
  const Eigen::Matrix3f cam_from_world_rotation = rotation.transpose();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  PacketRow<RenderPacket> rays(world_from_cam, k);
  const float inv_fx = float(1.0 / k.fx);
  for (int y = 0; y < k.height; ++y) {
    rays.start_row(y);
    for (int x0 = 0; x0 < k.width; x0 += kRenderLanes) {
      rays.trace(impl_->rtc_scene, &context, x0);
      const RenderPacket& packet = rays.packet();
      for (int lane = 0; lane < kRenderLanes && x0 + lane < k.width; ++lane) {
        const int x = x0 + lane;
        if (packet.hit.geomID[lane] == RTC_INVALID_GEOMETRY_ID) continue;  // allocate() filled the misses
        const unsigned triangle = packet.hit.primID[lane];
        const float t = packet.ray.tfar[lane];
        const Eigen::Vector3f direction(packet.ray.dir_x[lane], packet.ray.dir_y[lane], packet.ray.dir_z[lane]);
        out.depth.at(x, y) = t;
        if (request.triangle_ids) out.triangle_id.at(x, y) = static_cast<int>(triangle);
        const Eigen::Vector3f& normal = impl_->triangle_normals[triangle];
        const float ray_length = direction.norm();
        const float cos_incidence = std::abs(normal.dot(direction)) / ray_length;
        out.incidence_cos.at(x, y) = cos_incidence;
        if (request.normals) {
          const Eigen::Vector3f facing = normal.dot(direction) > 0.f ? Eigen::Vector3f(-normal) : normal;
          const Eigen::Vector3f normal_cam = cam_from_world_rotation * facing;
          for (int c = 0; c < 3; ++c) out.normal_cam.at(x, y, c) = normal_cam[c];
        }
        const float footprint = t * ray_length * inv_fx / std::sqrt(std::max(cos_incidence, 0.05f));
        const Eigen::Vector3f colour = impl_->shade(triangle, packet.hit.u[lane], packet.hit.v[lane],
                                                    origin + t * direction, direction, footprint);
        for (int c = 0; c < 3; ++c)
          out.rgb.at(x, y, c) = static_cast<std::uint8_t>(std::clamp(colour[c] * 255.f + 0.5f, 0.f, 255.f));
      }
    }
  }
  return out;
}

RenderedView Renderer::render(const Rigid3d& world_from_cam, const PinholeIntrinsics& intrinsics,
                              const RenderRequest& request, RenderTimes* times) const {
  RenderedView view = make_view(intrinsics, request, /*filled=*/false);  // every row rendered below
  tbb::parallel_for(tbb::blocked_range<int>(0, intrinsics.height, 8), [&](const tbb::blocked_range<int>& rows) {
    render_rows(world_from_cam, intrinsics, rows.begin(), rows.end(), view, request, times);
  });
  return view;
}

RenderedView Renderer::render_equirectangular(const Rigid3d& world_from_pano, const Equirectangular& pano) const {
  RenderedView view;
  const int width = pano.width(), height = pano.height;
  view.depth = ImageF32(width, height, 1, 0.f);
  view.rgb = ImageU8(width, height, 3, 0);
  view.incidence_cos = ImageF32(width, height, 1, 0.f);
  view.triangle_id = ImageI32(width, height, 1, -1);
  const Eigen::Matrix3d rotation = world_from_pano.linear();
  const Eigen::Vector3f origin = world_from_pano.translation().cast<float>();
  const double pixel_angle = M_PI / height;  // angular size of one panorama pixel
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 4), [&](const tbb::blocked_range<int>& rows) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit ray_hit;
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < width; ++x) {
        // Unit direction: the hit distance is the radial depth.
        const Eigen::Vector3f direction = (rotation * pano.direction(x, y)).cast<float>();
        setup_ray(ray_hit, origin, direction);
        rtcIntersect1(impl_->rtc_scene, &context, &ray_hit);
        if (ray_hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        const unsigned triangle = ray_hit.hit.primID;
        const float t = ray_hit.ray.tfar;
        view.depth.at(x, y) = t;
        view.triangle_id.at(x, y) = static_cast<int>(triangle);
        const float cos_incidence = std::abs(impl_->triangle_normals[triangle].dot(direction));
        view.incidence_cos.at(x, y) = cos_incidence;
        const float footprint = t * float(pixel_angle) / std::sqrt(std::max(cos_incidence, 0.05f));
        const Eigen::Vector3f colour =
            impl_->shade(triangle, ray_hit.hit.u, ray_hit.hit.v, origin + t * direction, direction, footprint);
        for (int c = 0; c < 3; ++c)
          view.rgb.at(x, y, c) = static_cast<std::uint8_t>(std::clamp(colour[c] * 255.f + 0.5f, 0.f, 255.f));
      }
  });
  return view;
}

std::size_t Renderer::intersect_only(const Rigid3d& world_from_cam, const PinholeIntrinsics& k, int row_begin,
                                     int row_end) const {
  const Eigen::Matrix3f rotation = world_from_cam.linear().cast<float>();
  const Eigen::Vector3f origin = world_from_cam.translation().cast<float>();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit ray_hit;
  std::size_t hits = 0;
  for (int y = row_begin; y < row_end; ++y)
    for (int x = 0; x < k.width; ++x) {
      setup_ray(ray_hit, origin, rotation * Eigen::Vector3f(float((x - k.cx) / k.fx), float((y - k.cy) / k.fy), 1.f));
      rtcIntersect1(impl_->rtc_scene, &context, &ray_hit);
      hits += ray_hit.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
  return hits;
}

namespace {

template <typename PacketRayHit>
std::size_t intersect_rows(RTCScene scene, const Rigid3d& world_from_cam, const PinholeIntrinsics& k, int row_begin,
                           int row_end) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  // The renderer's own packet set-up, so that the reference differs from the render by the
  // shading alone.
  PacketRow<PacketRayHit> rays(world_from_cam, k);
  constexpr int kLanes = PacketRow<PacketRayHit>::kLanes;
  std::size_t hits = 0;
  for (int y = row_begin; y < row_end; ++y) {
    rays.start_row(y);
    for (int x0 = 0; x0 < k.width; x0 += kLanes) {
      rays.trace(scene, &context, x0);
      for (int lane = 0; lane < kLanes; ++lane)
        hits += rays.valid(lane) && rays.packet().hit.geomID[lane] != RTC_INVALID_GEOMETRY_ID;
    }
  }
  return hits;
}

}  // namespace

std::size_t Renderer::intersect_only_packets(const Rigid3d& world_from_cam, const PinholeIntrinsics& k, int row_begin,
                                             int row_end) const {
  return intersect_rows<RTCRayHit8>(impl_->rtc_scene, world_from_cam, k, row_begin, row_end);
}

std::size_t Renderer::intersect_only_packets16(const Rigid3d& world_from_cam, const PinholeIntrinsics& k, int row_begin,
                                               int row_end) const {
  return intersect_rows<RTCRayHit16>(impl_->rtc_scene, world_from_cam, k, row_begin, row_end);
}

double Renderer::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int* triangle) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit ray_hit;
  setup_ray(ray_hit, origin.cast<float>(), direction.normalized().cast<float>());
  rtcIntersect1(impl_->rtc_scene, &context, &ray_hit);
  if (ray_hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
    if (triangle) *triangle = -1;
    return -1.0;
  }
  if (triangle) *triangle = static_cast<int>(ray_hit.hit.primID);
  return ray_hit.ray.tfar;
}

}  // namespace panoscan
