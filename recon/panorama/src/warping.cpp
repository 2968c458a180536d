// Paper §4.2, first step: each RGB-D frame becomes an organised mesh of its adjacent valid depth
// pixels (edges only where the depths differ by at most lambda_a) and is rasterised into the
// equirectangular panorama with the model-view T_u^-1 * T_ci; depth becomes the radial distance.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/allocator.h"
#include "panoscan/core/error.h"
#include "panoscan/recon/panorama.h"
#include "ray_table.h"

namespace panoscan {
namespace {

struct WarpVertex {
  Eigen::Vector3d point;    // in the panorama frame
  double u = 0.0, v = 0.0;  // continuous panorama pixel coordinates
  double radial = 0.0;
  const std::uint8_t* rgb = nullptr;
  bool near_pole = false;  // |z| > 0.9 radial: only such triangles can enclose a pole
  // ceil and floor of u and v: a triangle's box of pixel centres is [min ceil, max floor] in each
  // coordinate (both functions are monotonic, so this is ceil(min u) .. floor(max u) exactly), four
  // roundings per vertex instead of twelve per triangle.
  int u_ceil = 0, u_floor = 0, v_ceil = 0, v_floor = 0;
};

// One sample of one frame as warping emits it (12 bytes): the panorama pixel and the measurement's
// radial depth and colour; its sensor and frame are those of the frame's job. Each frame's samples
// are kept until all frames are warped, so every frame is read and warped once (the sizes of the
// measurement sets are only known at the end).
struct FrameSample {
  std::uint32_t pixel = 0;  // v * W + u; H <= 16384 (WarpOptions::check) gives at most 2^29 pixels
  float radial = 0.f;
  std::uint8_t rgb[3] = {0, 0, 0};
};
static_assert(sizeof(FrameSample) == 12, "FrameSample is meant to be 12 bytes");

// Per-thread buffers of warp_frame, reused from frame to frame (no allocation per frame).
struct WarpScratch {
  std::vector<WarpVertex> vertices[2];  // two rows of the frame
  std::vector<char> valid[2];
  // The same two rows' vertex boxes for the test of a whole 2x2 block (warp_frame): ceil and floor
  // of u and v (a pixel without a vertex gets values that widen no box) and whether the vertex is
  // near a pole.
  std::vector<int> u_ceil[2], u_floor[2], v_ceil[2], v_floor[2];
  std::vector<char> near_pole[2];
  std::vector<double> x, y, z, u, v;  // a row's points in the panorama frame and their pixels (SoA)
  std::vector<double> radial;         // their distances from the panorama's centre
  std::vector<double> column_factor;  // (x - cx) / fx of each column (the backprojection's division)
  std::vector<FrameSample> samples;
};

struct FrameJob {
  int sensor = 0;
  std::size_t frame = 0;
};

// The warped samples of the frames one worker thread warped, frame after frame, kept until all
// frames are warped. A chunk is reserved once (at least kChunkSamples, 48 MB, on huge pages) and
// filled without reallocation; each frame's samples lie in one chunk; a chunk's untouched reserve
// costs no memory. (Formerly each frame's samples were copied into a vector of their own: an
// allocation, a 4 KB page fault per 4 KB and an element-wise copy per frame, a tenth of the
// warping's time.) 48 MB is above the 32 MB up to which glibc keeps freed blocks in the process
// (keep_freed_memory_for_reuse): a chunk freed during the scatter goes back to the kernel at once,
// and the measurement sets, first touched during the scatter, get its pages back, recently used,
// instead of fresh ones (24 MB chunks stayed in the worker threads' heaps: 50 MB more peak and a
// slower scatter on the 2-core VM).
struct SampleChunk {
  struct Frame {
    std::size_t job = 0, begin = 0, end = 0;  // samples[begin, end) of jobs[job]
  };
  UninitialisedVector<FrameSample> samples;
  std::vector<Frame> frames;
};

struct SampleArena {
  static constexpr std::size_t kChunkSamples = std::size_t(1) << 22;
  std::vector<SampleChunk> chunks;
  void append(std::size_t job, const std::vector<FrameSample>& frame_samples) {
    const std::size_t n = frame_samples.size();
    if (chunks.empty() || chunks.back().samples.capacity() - chunks.back().samples.size() < n) {
      chunks.emplace_back();
      chunks.back().samples.reserve(std::max(kChunkSamples, n));
    }
    SampleChunk& chunk = chunks.back();
    const std::size_t begin = chunk.samples.size();
    chunk.samples.insert(chunk.samples.end(), frame_samples.begin(), frame_samples.end());  // within capacity
    chunk.frames.push_back({job, begin, begin + n});
  }
};

// Rasterises one triangle; calls emit(pixel_index, radial, rgb) for every panorama pixel centre
// inside it. Returns false if the triangle encloses a pole (skipped).
template <typename Emit>
bool rasterise_triangle(const Equirectangular& pano, const RayTable& rays, const WarpVertex& a, const WarpVertex& b,
                        const WarpVertex& c, const Emit& emit) {
  const int width = pano.width();
  const int height = pano.height;
  double us[3] = {a.u, b.u, c.u};
  const double vs[3] = {a.v, b.v, c.v};
  // Seam at azimuth 0 / 2 pi: a triangle whose columns span more than half the panorama crosses
  // it; move its left-side vertices by +W and wrap the pixel columns back when emitting.
  const double u_min0 = std::min({us[0], us[1], us[2]});
  const double u_max0 = std::max({us[0], us[1], us[2]});
  if (u_max0 - u_min0 > 0.5 * width)
    for (double& u : us)
      if (u < 0.5 * width) u += width;
  // Most triangles are smaller than a panorama pixel and contain no pixel centre. Without a vertex
  // near a pole (the pole test below cannot skip the triangle) the empty bounding box is tested
  // first; otherwise in the order normal, pole, box. Either way a triangle returns what it did when
  // the box came last: an empty box and a zero normal both return true.
  const bool near_pole = a.near_pole || b.near_pole || c.near_pole;
  const double u_lo = std::min({us[0], us[1], us[2]}), u_hi = std::max({us[0], us[1], us[2]});
  const double v_lo = std::min({vs[0], vs[1], vs[2]}), v_hi = std::max({vs[0], vs[1], vs[2]});
  const int ui0 = int(std::ceil(u_lo)), ui1 = int(std::floor(u_hi));
  const int vi0 = std::max(0, int(std::ceil(v_lo))), vi1 = std::min(height - 1, int(std::floor(v_hi)));
  const bool empty_box = ui1 < ui0 || vi1 < vi0;
  if (!near_pole && empty_box) return true;
  const WarpVertex* verts[3] = {&a, &b, &c};
  const Eigen::Vector3d normal = (b.point - a.point).cross(c.point - a.point);
  // The test on the squared norm (sqrt(x) <= 0 exactly when x <= 0, NaN neither) keeps the square
  // root's latency off this branch; the root is only needed in the pixel loop.
  const double normal_norm2 = normal.squaredNorm();
  if (normal_norm2 <= 0.0) return true;
  const double normal_norm = std::sqrt(normal_norm2);
  // Pole: the panorama ray straight up or down passes through the triangle (its projection would
  // wrap all the way round). Only possible when a vertex is near a pole.
  for (const WarpVertex* vtx : verts) {
    if (vtx->near_pole) {
      for (const double sign : {1.0, -1.0}) {
        // Does the ray t * (0, 0, sign) hit the triangle? Signs of the three edge volumes.
        const Eigen::Vector3d d(0, 0, sign);
        const double s0 = d.dot(a.point.cross(b.point));
        const double s1 = d.dot(b.point.cross(c.point));
        const double s2 = d.dot(c.point.cross(a.point));
        if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return false;
      }
      break;
    }
  }
  if (empty_box) return true;
  if (double(ui1 - ui0 + 1) * double(vi1 - vi0 + 1) > 4096.0) return true;  // degenerate sliver
  const double area2 = (us[1] - us[0]) * (vs[2] - vs[0]) - (us[2] - us[0]) * (vs[1] - vs[0]);
  if (std::abs(area2) < 1e-12) return true;
  const double r_min = std::min({a.radial, b.radial, c.radial});
  const double r_max = std::max({a.radial, b.radial, c.radial});
  for (int v = vi0; v <= vi1; ++v) {
    for (int u = ui0; u <= ui1; ++u) {
      // Barycentric coordinates of the pixel centre in panorama pixel space.
      const double w1 = ((u - us[0]) * (vs[2] - vs[0]) - (us[2] - us[0]) * (v - vs[0])) / area2;
      const double w2 = ((us[1] - us[0]) * (v - vs[0]) - (u - us[0]) * (vs[1] - vs[0])) / area2;
      const double w0 = 1.0 - w1 - w2;
      if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
      // u is in [0, 2 W) (u >= ceil(-0.5), unwrapped by at most +W): one subtraction, not two
      // integer divisions, wraps it.
      const int u_wrapped = u >= width ? u - width : (u < 0 ? u + width : u);
      // Radial depth: where the pixel's ray meets the triangle's plane (the 3D position is
      // interpolated along the ray, exact for planar surfaces); barycentric fallback where the
      // plane is grazing.
      const Eigen::Vector3d ray = rays(u_wrapped, v);
      const double denom = normal.dot(ray);
      double radial = -1.0;
      if (std::abs(denom) > 1e-6 * normal_norm) radial = normal.dot(a.point) / denom;
      if (!(radial >= 0.9 * r_min && radial <= 1.01 * r_max)) radial = w0 * a.radial + w1 * b.radial + w2 * c.radial;
      std::uint8_t rgb[3];
      for (int ch = 0; ch < 3; ++ch) {
        // std::lround of a value in [0, 255] (half away from zero), without the library call: the
        // fraction x - trunc(x) is exact for x >= 0.
        const double value = std::clamp(w0 * a.rgb[ch] + w1 * b.rgb[ch] + w2 * c.rgb[ch], 0.0, 255.0);
        const int whole = int(value);
        rgb[ch] = std::uint8_t(whole + (value - whole >= 0.5 ? 1 : 0));
      }
      emit(std::size_t(v) * width + u_wrapped, float(radial), rgb);
    }
  }
  return true;
}

// Warps one frame: builds the organised mesh (two triangles per 2x2 block of valid pixels whose
// depths differ pairwise by at most lambda_a) and rasterises it into scratch.samples (cleared first).
// Returns the number of triangles skipped at the poles.
std::size_t warp_frame(const RgbdFrame& frame, const PinholeIntrinsics& intrinsics, const Rigid3d& pano_from_cam,
                       const Equirectangular& pano, const RayTable& rays, const WarpOptions& options,
                       WarpScratch& scratch) {
  const int w = frame.depth.width, h = frame.depth.height;
  // Two rows of vertices, the 2x2 blocks' upper and lower row, in turn: they stay in the cache
  // (a frame-sized array, 24 MB at 640x480, did not; the triangle loop waited on its loads).
  // A vertex is only read where its valid flag is set, so the rows are not cleared.
  for (int r = 0; r < 2; ++r) {
    if (scratch.vertices[r].size() < std::size_t(w)) scratch.vertices[r].resize(std::size_t(w));
    scratch.valid[r].assign(std::size_t(w), 0);
  }
  std::vector<FrameSample>& samples = scratch.samples;
  samples.clear();
  for (auto* row : {&scratch.x, &scratch.y, &scratch.z, &scratch.u, &scratch.v, &scratch.radial})
    row->resize(std::size_t(w));
  double *const row_x = scratch.x.data(), *const row_y = scratch.y.data(), *const row_z = scratch.z.data();
  double* const row_radial = scratch.radial.data();
  // PinholeIntrinsics::backproject's (x - cx) / fx, once per column instead of once per pixel.
  scratch.column_factor.resize(std::size_t(w));
  for (int x = 0; x < w; ++x) scratch.column_factor[std::size_t(x)] = (x - intrinsics.cx) / intrinsics.fx;
  const double* const column_factor = scratch.column_factor.data();
  // pano_from_cam's matrix: the products below are Eigen's for `pano_from_cam * point` and
  // `point.norm()` (translation + ((m0 x + m1 y) + m2 z) per row, sqrt((x x + y y) + z z)), written
  // out so that the loop has no branch and vectorises.
  const Eigen::Matrix<double, 3, 4> m = pano_from_cam.matrix().topRows<3>();
  const double m00 = m(0, 0), m01 = m(0, 1), m02 = m(0, 2), m03 = m(0, 3);
  const double m10 = m(1, 0), m11 = m(1, 1), m12 = m(1, 2), m13 = m(1, 3);
  const double m20 = m(2, 0), m21 = m(2, 1), m22 = m(2, 2), m23 = m(2, 3);
  const double min_depth = options.min_depth_m, max_depth = options.max_depth_m;
  // A row in three passes: the points and their distances for the whole row, branch free (pixels
  // without a vertex get a harmless direction for the next pass), two pixels per SSE2 instruction
  // (square roots and products rounded as the scalar ones); their panorama pixels
  // (Equirectangular::pixels, SIMD); then the vertices.
  for (int r = 0; r < 2; ++r)
    for (auto* row : {&scratch.u_ceil[r], &scratch.u_floor[r], &scratch.v_ceil[r], &scratch.v_floor[r]})
      row->resize(std::size_t(w));
  for (auto& row : scratch.near_pole) row.resize(std::size_t(w));
  auto build_row = [&](int y, int slot) {
    WarpVertex* const vertices = scratch.vertices[slot].data();
    char* const valid = scratch.valid[slot].data();
    int *const u_ceil = scratch.u_ceil[slot].data(), *const u_floor = scratch.u_floor[slot].data();
    int *const v_ceil = scratch.v_ceil[slot].data(), *const v_floor = scratch.v_floor[slot].data();
    char* const near_pole = scratch.near_pole[slot].data();
    const float* const depth_row = &frame.depth.data[std::size_t(y) * w];
    const double row_factor = (y - intrinsics.cy) / intrinsics.fy;
    int x = 0;
#if defined(__SSE2__)
    {
      const auto set = [](double v) { return _mm_set1_pd(v); };
      const auto select = [](__m128d mask, __m128d a, __m128d b) {
        return _mm_or_pd(_mm_and_pd(mask, a), _mm_andnot_pd(mask, b));
      };
      const __m128d zero = _mm_setzero_pd(), one = set(1.0), min_v = set(min_depth), max_v = set(max_depth);
      const __m128d no_max = max_depth > 0 ? zero : _mm_castsi128_pd(_mm_set1_epi32(-1));  // all ones: no limit
      for (; x + 2 <= w; x += 2) {
        // float -> double is exact, so the comparisons are the scalar loop's.
        const __m128d depth =
            _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(depth_row + x))));
        const __m128d in_range =
            _mm_and_pd(_mm_and_pd(_mm_cmpgt_pd(depth, zero), _mm_cmpeq_pd(_mm_sub_pd(depth, depth), zero)),
                       _mm_and_pd(_mm_cmpge_pd(depth, min_v), _mm_or_pd(no_max, _mm_cmple_pd(depth, max_v))));
        const __m128d z = select(in_range, depth, one);
        const __m128d cam_x = _mm_mul_pd(_mm_loadu_pd(column_factor + x), z), cam_y = _mm_mul_pd(set(row_factor), z);
        const auto row_of = [&](double a, double b, double c, double t) {
          return _mm_add_pd(set(t), _mm_add_pd(_mm_add_pd(_mm_mul_pd(set(a), cam_x), _mm_mul_pd(set(b), cam_y)),
                                               _mm_mul_pd(set(c), z)));
        };
        const __m128d px = row_of(m00, m01, m02, m03), py = row_of(m10, m11, m12, m13), pz = row_of(m20, m21, m22, m23);
        const __m128d radial =
            _mm_sqrt_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(px, px), _mm_mul_pd(py, py)), _mm_mul_pd(pz, pz)));
        const __m128d vertex = _mm_and_pd(in_range, _mm_cmpgt_pd(radial, set(1e-6)));
        const int mask = _mm_movemask_pd(vertex);
        valid[x] = char(mask & 1);
        valid[x + 1] = char(mask >> 1);
        _mm_storeu_pd(row_x + x, select(vertex, px, one));
        _mm_storeu_pd(row_y + x, select(vertex, py, zero));
        _mm_storeu_pd(row_z + x, select(vertex, pz, zero));
        _mm_storeu_pd(row_radial + x, radial);
      }
    }
#endif
    for (; x < w; ++x) {
      const float depth = depth_row[x];
      // z > 0, finite (z - z is 0 only then) and within [min_depth_m, max_depth_m].
      const bool in_range = depth > 0.f && depth - depth == 0.f && double(depth) >= min_depth &&
                            !(max_depth > 0 && double(depth) > max_depth);
      const double z = in_range ? double(depth) : 1.0;
      const double cam_x = column_factor[x] * z, cam_y = row_factor * z;
      const double px = m03 + ((m00 * cam_x + m01 * cam_y) + m02 * z);
      const double py = m13 + ((m10 * cam_x + m11 * cam_y) + m12 * z);
      const double pz = m23 + ((m20 * cam_x + m21 * cam_y) + m22 * z);
      const double radial = std::sqrt((px * px + py * py) + pz * pz);
      const bool vertex = in_range && radial > 1e-6;
      valid[x] = char(vertex);
      row_x[x] = vertex ? px : 1.0;
      row_y[x] = vertex ? py : 0.0;
      row_z[x] = vertex ? pz : 0.0;
      row_radial[x] = radial;
    }
    pano.pixels(std::size_t(w), row_x, row_y, row_z, scratch.u.data(), scratch.v.data());
    for (int x = 0; x < w; ++x) {
      if (!valid[x]) {
        u_ceil[x] = v_ceil[x] = std::numeric_limits<int>::max();
        u_floor[x] = v_floor[x] = std::numeric_limits<int>::min();
        near_pole[x] = 0;
        continue;
      }
      WarpVertex& vtx = vertices[x];
      vtx.point = Eigen::Vector3d(row_x[x], row_y[x], row_z[x]);
      vtx.radial = row_radial[x];
      vtx.u = scratch.u[std::size_t(x)];
      vtx.v = scratch.v[std::size_t(x)];
      vtx.rgb = &frame.rgb.data[(std::size_t(y) * w + x) * 3];
      vtx.near_pole = std::abs(vtx.point.z()) > 0.9 * vtx.radial;
      vtx.u_ceil = int(std::ceil(vtx.u));
      vtx.u_floor = int(std::floor(vtx.u));
      vtx.v_ceil = int(std::ceil(vtx.v));
      vtx.v_floor = int(std::floor(vtx.v));
      u_ceil[x] = vtx.u_ceil, u_floor[x] = vtx.u_floor, v_ceil[x] = vtx.v_ceil, v_floor[x] = vtx.v_floor;
      near_pole[x] = char(vtx.near_pole);
    }
  };
  const double jump = options.max_edge_depth_jump_m;
  auto connected = [&](std::size_t i, std::size_t j) {
    return std::abs(double(frame.depth.data[i]) - double(frame.depth.data[j])) <= jump;
  };
  const auto emit = [&](std::size_t pixel, float radial, const std::uint8_t* rgb) {
    FrameSample& sample = samples.emplace_back();
    sample.pixel = std::uint32_t(pixel);
    sample.radial = radial;
    sample.rgb[0] = rgb[0];
    sample.rgb[1] = rgb[1];
    sample.rgb[2] = rgb[2];
  };
  // Most triangles are smaller than a panorama pixel and contain no pixel centre: this inline test
  // drops those whose box of pixel centres is empty, exactly where rasterise_triangle would return
  // true without emitting (no vertex near a pole, not across the seam); the others go to it.
  const int pano_width = pano.width(), pano_height = pano.height;
  auto may_cover = [&](const WarpVertex& a, const WarpVertex& b, const WarpVertex& c) {
    if (a.near_pole || b.near_pole || c.near_pole) return true;
    if (std::max({a.u, b.u, c.u}) - std::min({a.u, b.u, c.u}) > 0.5 * pano_width) return true;  // seam
    const int ui0 = std::min({a.u_ceil, b.u_ceil, c.u_ceil}), ui1 = std::max({a.u_floor, b.u_floor, c.u_floor});
    const int vi0 = std::max(0, std::min({a.v_ceil, b.v_ceil, c.v_ceil}));
    const int vi1 = std::min(pano_height - 1, std::max({a.v_floor, b.v_floor, c.v_floor}));
    return ui0 <= ui1 && vi0 <= vi1;
  };
  auto rasterise = [&](const WarpVertex& a, const WarpVertex& b, const WarpVertex& c) {
    return !may_cover(a, b, c) || rasterise_triangle(pano, rays, a, b, c, emit);
  };
  std::size_t pole_skips = 0;
  if (h > 0) build_row(0, 0);
  for (int y = 0; y + 1 < h; ++y) {
    const int t = y & 1, b = (y + 1) & 1;
    build_row(y + 1, b);
    const WarpVertex* top = scratch.vertices[t].data();
    const char* top_valid = scratch.valid[t].data();
    const WarpVertex* bottom = scratch.vertices[b].data();
    const char* bottom_valid = scratch.valid[b].data();
    const int *const uc_t = scratch.u_ceil[t].data(), *const uc_b = scratch.u_ceil[b].data();
    const int *const uf_t = scratch.u_floor[t].data(), *const uf_b = scratch.u_floor[b].data();
    const int *const vc_t = scratch.v_ceil[t].data(), *const vc_b = scratch.v_ceil[b].data();
    const int *const vf_t = scratch.v_floor[t].data(), *const vf_b = scratch.v_floor[b].data();
    const char *const pole_t = scratch.near_pole[t].data(), *const pole_b = scratch.near_pole[b].data();
    for (int x = 0; x + 1 < w; ++x) {
      // The block as a whole first: its two triangles' boxes of pixel centres lie inside the box
      // of its vertices (those with depth). Where that box is empty, no vertex is near a pole and
      // the block does not span half the panorama (the seam: max u - min u < u_floor's max -
      // u_ceil's min + 2), may_cover is false for both triangles: nothing to do. Three blocks in
      // four at H = 1024.
      const int u_lo = std::min(std::min(uc_t[x], uc_t[x + 1]), std::min(uc_b[x], uc_b[x + 1]));
      const int u_hi = std::max(std::max(uf_t[x], uf_t[x + 1]), std::max(uf_b[x], uf_b[x + 1]));
      const int v_lo = std::max(0, std::min(std::min(vc_t[x], vc_t[x + 1]), std::min(vc_b[x], vc_b[x + 1])));
      const int v_hi =
          std::min(pano_height - 1, std::max(std::max(vf_t[x], vf_t[x + 1]), std::max(vf_b[x], vf_b[x + 1])));
      const bool pole = (pole_t[x] | pole_t[x + 1] | pole_b[x] | pole_b[x + 1]) != 0;
      if (!pole && (u_lo > u_hi || (v_lo > v_hi && std::int64_t(u_hi) - u_lo + 2 <= std::int64_t(pano_width / 2))))
        continue;
      // Depth indices of the block's corners 00, 10 (right), 01 (below), 11.
      const std::size_t i00 = std::size_t(y) * w + x, i10 = i00 + 1, i01 = i00 + w, i11 = i01 + 1;
      // Triangle (00, 10, 01) and triangle (10, 11, 01).
      if (top_valid[x] && top_valid[x + 1] && bottom_valid[x] && connected(i00, i10) && connected(i00, i01) &&
          connected(i10, i01))
        if (!rasterise(top[x], top[x + 1], bottom[x])) ++pole_skips;
      if (top_valid[x + 1] && bottom_valid[x + 1] && bottom_valid[x] && connected(i10, i11) && connected(i11, i01) &&
          connected(i10, i01))
        if (!rasterise(top[x + 1], bottom[x + 1], bottom[x])) ++pole_skips;
    }
  }
  return pole_skips;
}

// The depth pixels warp_frame uses (the same test as its vertex loop).
std::size_t count_valid_depth(const ImageF32& depth, const WarpOptions& options) {
  std::size_t valid = 0;
  for (const float z : depth.data)
    if (z > 0.f && std::isfinite(z) && z >= options.min_depth_m && (options.max_depth_m <= 0 || z <= options.max_depth_m))
      ++valid;
  return valid;
}

bool pose_is_finite(const Rigid3d& pose) { return pose.matrix().allFinite(); }

}  // namespace

void WarpOptions::check(const std::string& origin) const {
  if (height < 4 || height > 16384) throw make_error(origin, "panorama.height", "must be in [4, 16384]");
  if (!(max_edge_depth_jump_m > 0)) throw make_error(origin, "panorama.lambda_a_m", "must be > 0");
  if (!(min_depth_m >= 0)) throw make_error(origin, "panorama.min_depth_m", "must be >= 0");
  if (!(max_depth_m >= 0)) throw make_error(origin, "panorama.max_depth_m", "must be >= 0 (0 = no limit)");
  if (max_depth_m > 0 && max_depth_m <= min_depth_m)
    throw make_error(origin, "panorama.max_depth_m", "must exceed panorama.min_depth_m");
  if (frame_stride < 1) throw make_error(origin, "panorama.frame_stride", "must be >= 1");
  if (!(min_valid_depth_share >= 0 && min_valid_depth_share <= 1))
    throw make_error(origin, "panorama.min_valid_depth_share", "must be in [0, 1]");
}

PanoramaMeasurements warp_frames(const ScanIndex& scan, const RigTrajectory& trajectory, const WarpOptions& options) {
  options.check();
  check_rig_trajectory(trajectory, scan, "poses");
  if (!pose_is_finite(trajectory.world_from_axis)) throw make_error("poses", "world_from_axis", "not finite");
  PanoramaMeasurements out;
  out.pano.height = options.height;
  out.world_from_pano = trajectory.world_from_axis;
  const Rigid3d pano_from_world = trajectory.world_from_axis.inverse();
  std::vector<FrameJob> jobs;
  for (std::size_t s = 0; s < scan.frames.size(); ++s)
    for (std::size_t f = 0; f < scan.frames[s].size(); f += std::size_t(options.frame_stride))
      jobs.push_back({int(s), f});
  if (jobs.empty()) throw make_error(scan.root.string(), "frames", "the scan has no frames");
  if (scan.frames.size() > 255) throw make_error(scan.root.string(), "sensors", "more than 255 sensors");
  const std::size_t pixels = std::size_t(out.pano.width()) * out.pano.height;

  auto pano_from_cam = [&](const FrameJob& job) {
    return Rigid3d(pano_from_world * trajectory.world_from_cam[job.sensor][job.frame].world_from_cam);
  };
  // Every frame is read and warped once, in parallel; its samples are kept in its thread's arena
  // (12 bytes each, the size of a measurement). Then the per-pixel counts give the CSR offsets,
  // and each arena chunk's samples are scattered into their pixels' sets (positions within a set
  // depend on the scheduling) and the chunk freed, and each set is sorted, which makes the layout
  // independent of the thread count. (Formerly every frame was read and warped twice, once to count and once to
  // scatter, to keep memory to the CSR array alone: decoding and warping were most of the time.)
  const RayTable rays(out.pano);
  tbb::enumerable_thread_specific<WarpScratch> scratch;
  tbb::enumerable_thread_specific<SampleArena> arenas;
  std::atomic<std::size_t> pole_skips{0}, frame_pixels{0}, valid_frame_pixels{0};
  tbb::parallel_for(std::size_t(0), jobs.size(), [&](std::size_t j) {
    const FrameJob& job = jobs[j];
    const RgbdFrame frame = load_frame(scan, job.sensor, job.frame);
    frame_pixels += frame.depth.data.size();
    valid_frame_pixels += count_valid_depth(frame.depth, options);
    WarpScratch& local = scratch.local();
    pole_skips +=
        warp_frame(frame, scan.rig.sensors[job.sensor].intrinsics, pano_from_cam(job), out.pano, rays, options, local);
    arenas.local().append(j, local.samples);
  });
  scratch.clear();
  std::vector<SampleChunk> chunks;
  for (SampleArena& arena : arenas)
    for (SampleChunk& chunk : arena.chunks) chunks.push_back(std::move(chunk));
  arenas.clear();
  out.frame_pixels = frame_pixels.load();
  out.valid_frame_pixels = valid_frame_pixels.load();
  const double valid_share = out.frame_pixels ? double(out.valid_frame_pixels) / double(out.frame_pixels) : 0.0;
  if (valid_share < options.min_valid_depth_share)
    throw make_error(scan.root.string(), "depth",
                     fmt::format("only {:.1f}% of the pixels of the {} frames used have depth in range (at least "
                                 "{:.0f}% expected, panorama.min_valid_depth_share): a wrong depth_scale in "
                                 "rig.json, a covered sensor or a scan of empty space?",
                                 100.0 * valid_share, jobs.size(), 100.0 * options.min_valid_depth_share));
  // Each chunk's samples are scattered into their pixels' sets without atomic operations: the
  // chunks are dealt to `groups` groups (chunk c to group c % groups), each group with its own
  // per-pixel counts and, in the same array, its cursors; a pixel's set takes group 0's samples
  // first, then group 1's, ... (the sort below makes the order canonical). An atomic counter per
  // pixel was a locked instruction per sample, which waits until the stores before it are done:
  // the previous sample's store into the sets, a cache miss, so the misses ran one at a time.
  const std::size_t groups = std::max<std::size_t>(
      1, std::min<std::size_t>({chunks.size(), 4, std::size_t(tbb::this_task_arena::max_concurrency())}));
  std::vector<UninitialisedVector<std::uint32_t>> cursors(groups);
  tbb::parallel_for(std::size_t(0), groups, [&](std::size_t g) {
    UninitialisedVector<std::uint32_t>& count = cursors[g];
    count.assign(pixels, 0);
    for (std::size_t c = g; c < chunks.size(); c += groups)
      for (const FrameSample& sample : chunks[c].samples) ++count[sample.pixel];
  });
  out.offsets.assign(pixels + 1, 0);
  for (std::size_t p = 0; p < pixels; ++p) {
    std::uint32_t in_set = 0;  // a group's cursor: where its first sample goes in the pixel's set
    for (UninitialisedVector<std::uint32_t>& cursor : cursors) {
      const std::uint32_t count = cursor[p];
      cursor[p] = in_set;
      in_set += count;
    }
    out.offsets[p + 1] = out.offsets[p] + in_set;
  }
  out.samples.resize(out.offsets[pixels]);
  tbb::parallel_for(std::size_t(0), groups, [&](std::size_t g) {
    std::uint32_t* const cursor = cursors[g].data();
    for (std::size_t c = g; c < chunks.size(); c += groups) {
      const SampleChunk& chunk = chunks[c];
      for (const SampleChunk::Frame& span : chunk.frames) {
        const FrameJob& job = jobs[span.job];
        for (std::size_t k = span.begin; k < span.end; ++k) {
          const FrameSample& sample = chunk.samples[k];
          PanoramaMeasurement& m = out.samples[out.offsets[sample.pixel] + cursor[sample.pixel]++];
          m.radial_m = sample.radial;
          m.rgb[0] = sample.rgb[0];
          m.rgb[1] = sample.rgb[1];
          m.rgb[2] = sample.rgb[2];
          m.sensor = std::uint8_t(job.sensor);
          m.frame = std::uint32_t(job.frame);
        }
      }
      UninitialisedVector<FrameSample>().swap(chunks[c].samples);  // frees the chunk
    }
  });
  cursors.clear();
  tbb::parallel_for(std::size_t(0), pixels, [&](std::size_t p) {
    auto begin = out.samples.begin() + std::ptrdiff_t(out.offsets[p]);
    auto end = out.samples.begin() + std::ptrdiff_t(out.offsets[p + 1]);
    std::sort(begin, end, [](const PanoramaMeasurement& x, const PanoramaMeasurement& y) {
      if (x.sensor != y.sensor) return x.sensor < y.sensor;
      if (x.frame != y.frame) return x.frame < y.frame;
      if (x.radial_m != y.radial_m) return x.radial_m < y.radial_m;
      return std::lexicographical_compare(x.rgb, x.rgb + 3, y.rgb, y.rgb + 3);
    });
  });
  out.frames_used = jobs.size();
  out.triangles_skipped_at_poles = pole_skips.load();
  return out;
}

}  // namespace panoscan
