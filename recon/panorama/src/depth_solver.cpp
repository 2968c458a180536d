// Paper §4.2, fusion: colour by averaging; radial depth by minimising Eq. 5,
//   E(D) = sum_p sum_k |D_p - z_pk| + lambda_b * sum_p S_p(D),
// with S the TV (on the cylindrical radius or on the radial depth), TSA (Eq. 6) or TP (Eq. 7) term;
// each term is a named function in depth_terms.h.
// Solver: L-BFGS with Armijo backtracking on the smoothed energy (|x| -> sqrt(x^2 + eps^2) - eps),
// started from the per-pixel median (the minimiser of the data term alone).
// Parallel over pixels with oneTBB; every reduction sums fixed-size chunks in a fixed order, so the
// result does not depend on the thread count.
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "depth_energy.h"
#include "depth_terms.h"
#include "ray_table.h"
#include "panoscan/core/allocator.h"
#include "panoscan/core/cpu_features.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/panorama.h"

namespace panoscan {
namespace {

constexpr std::size_t kChunk = 4096;

// The solver's per-unknown and per-measurement arrays. Each is written in full by a parallel loop
// before it is read, so sizing it does not zero-fill it (core/allocator.h).
using Buffer = UninitialisedVector<double>;

// Deterministic parallel sum of f(i) over [0, n): fixed chunks, summed in order.
template <typename F>
double chunked_sum(std::size_t n, const F& f) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> partial(chunks, 0.0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    double sum = 0.0;
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) sum += f(i);
    partial[c] = sum;
  });
  double total = 0.0;
  for (const double value : partial) total += value;
  return total;
}

// The same for K sums at once (f returns std::array<double, K>): each sum as chunked_sum takes it.
template <std::size_t K, typename F>
std::array<double, K> chunked_sums(std::size_t n, const F& f) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::array<double, K>> partial(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    std::array<double, K> sum{};
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const std::array<double, K> terms = f(i);
      for (std::size_t k = 0; k < K; ++k) sum[k] += terms[k];
    }
    partial[c] = sum;
  });
  std::array<double, K> total{};
  for (const auto& value : partial)
    for (std::size_t k = 0; k < K; ++k) total[k] += value[k];
  return total;
}

// The unknowns: one radial depth per pixel with at least one measurement.
struct DepthProblem {
  const PanoramaMeasurements* m = nullptr;
  // The measurements' radial depths in CSR order (m->offsets index it), then as many zeros as the
  // largest set has measurements (data_term_quad reads that far past a set's end):
  // the data term reads 4 bytes per measurement instead of 12 (at H = 1024, 69 MB instead of 207 MB
  // per evaluation).
  UninitialisedVector<float> radial;
  DepthFusionMethod method = DepthFusionMethod::kTsa;
  double lambda = 0.0;
  double data_eps = 0.002, tv_eps = 1e-4, tsa_eps = 1e-7;
  std::vector<std::size_t> pixel;  // pixel index of each unknown
  // The unit direction of each unknown's pixel, ray(i), from its column and row through the
  // panorama's ray tables: 4 bytes per unknown instead of a 24-byte vector (each evaluation reads
  // three rays per unknown; at H = 1024 the vectors were 48 MB per pass over them).
  std::unique_ptr<const RayTable> rays;
  UninitialisedVector<std::uint16_t> column, row;
  Eigen::Vector3d ray(std::size_t i) const { return (*rays)(column[i], row[i]); }
  Buffer sin_theta;
  UninitialisedVector<int> left, right, up, down;  // neighbouring unknowns (azimuth periodic), -1 = none

  struct Parts {
    double smoothed = 0.0, data = 0.0, smoothness = 0.0;
  };

  // TP's stencil has all four neighbours; TV and TSA use the anchor and its left and upper ones.
  bool uses_right_down() const { return method == DepthFusionMethod::kTp; }
  // Diagonal curvature estimate at the last evaluate(x, grad): data term's Hessian diagonal plus
  // lambda times the smoothness term's (majorised) diagonal; the L-BFGS preconditioner.
  mutable Buffer data_curvature;

  // The unknowns of panorama row v are [row_begin[v], row_begin[v + 1]) (they are numbered in
  // pixel order, so each row's are consecutive).
  std::vector<std::size_t> row_begin;
  std::size_t max_row_size = 0;  // the most unknowns in one row

  // A smoothness term anchored at an unknown has partial derivatives with respect to the depths of
  // its stencil (depth_terms.h Slot): the anchor's own and, by role, its left, right, upper and lower
  // neighbours'. An unknown's gradient gathers the terms that involve it: its own as anchor, its
  // right neighbour's (where it is the left one), its lower neighbour's (where it is the upper one),
  // and for TP its left and upper neighbours' too. evaluate() streams the panorama by rows and keeps
  // the terms of three rows (the one being finished and the rows above and below it) instead of
  // five per-unknown arrays per role written in one pass and gathered in another (at H = 1024 those
  // were 96 MB written and read back per evaluation).
  struct RowTerms {
    std::array<std::vector<double>, depth_terms::kSlots> gradient, curvature;  // [role][unknown - row begin]
    std::array<std::vector<double>, 3> ray;  // TSA: the unknowns' rays, component by component
  };
  struct RowScratch {
    RowTerms rows[3];  // row v in rows[v % 3]
    // Along the row being computed (index: unknown - row begin): the smoothness terms' values,
    // whether the anchor's term is summed into the energy, and the data terms.
    std::vector<double> smoothed, exact;
    std::vector<char> has_smoothness;
    std::vector<depth_terms::DataTerm> data;
  };
  mutable tbb::enumerable_thread_specific<RowScratch> row_scratch;

  std::size_t size() const { return pixel.size(); }

  // The smoothness term S_p of Eq. 5 anchored at unknown i (lambda not applied): TV, TSA (Eq. 6)
  // or TP (Eq. 7) on the stencil of its neighbouring unknowns (depth_terms.h).
  depth_terms::StencilTerm smoothness_term(const Buffer& x, std::size_t i) const {
    using namespace depth_terms;
    // TV and TSA read the anchor, left and upper slots only: the others are left absent.
    const bool all = uses_right_down();
    const std::array<int, kSlots> index = {int(i), left[i], all ? right[i] : -1, up[i], all ? down[i] : -1};
    Stencil stencil;
    for (int k = 0; k < kSlots; ++k) {
      stencil.present[k] = index[k] >= 0;
      if (!stencil.present[k]) {
        stencil.ray[k].setZero();  // never read for an absent slot; set so that no value is indeterminate
        continue;
      }
      const std::size_t j = std::size_t(index[k]);
      stencil.depth[k] = x[j];
      stencil.ray[k] = ray(j);
      stencil.sin_theta[k] = sin_theta[j];
    }
    switch (method) {
      case DepthFusionMethod::kAverage: return {};
      case DepthFusionMethod::kTvCylindrical: return tv_term(stencil, true, tv_eps);
      case DepthFusionMethod::kTvRadial: return tv_term(stencil, false, tv_eps);
      case DepthFusionMethod::kTsa: return tsa_term(stencil, tsa_eps);
      case DepthFusionMethod::kTp: return tp_term(stencil);
    }
    return {};
  }

  // The data terms of `count` unknowns from `first` on (count <= group_size) into out: four per
  // AVX data_term_quad where the CPU has AVX, otherwise two per SSE2 data_term_pair. Every value is
  // data_term's bit for bit either way.
  const std::size_t group_size = data_term_quads() ? 4 : 2;
  static bool data_term_quads() {
#if defined(PANOSCAN_DEPTH_TERMS_AVX)
    return cpu::has_avx();
#else
    return false;
#endif
  }
  void data_terms(const Buffer& x, std::size_t first, std::size_t count, depth_terms::DataTerm* out) const {
    const auto begin = [&](std::size_t i) { return radial.data() + m->offsets[pixel[i]]; };
    const auto end = [&](std::size_t i) { return radial.data() + m->offsets[pixel[i] + 1]; };
#if defined(PANOSCAN_DEPTH_TERMS_AVX)
    if (count == 4 && group_size == 4) {
      const double depth[4] = {x[first], x[first + 1], x[first + 2], x[first + 3]};
      const float* const begins[4] = {begin(first), begin(first + 1), begin(first + 2), begin(first + 3)};
      const float* const ends[4] = {end(first), end(first + 1), end(first + 2), end(first + 3)};
      depth_terms::data_term_quad(depth, begins, ends, data_eps, out);
      return;
    }
#endif
    for (std::size_t j = 0; j < count; j += 2) {
      const std::size_t i = first + j;
      if (j + 1 < count)
        depth_terms::data_term_pair(x[i], begin(i), end(i), x[i + 1], begin(i + 1), end(i + 1), data_eps, out[j],
                                    out[j + 1]);
      else
        out[j] = depth_terms::data_term(x[i], begin(i), end(i), data_eps);
    }
  }

  // The rays of row v's unknowns into rows[v % 3].ray: TSA reads each unknown's ray three times,
  // as anchor and as its right and lower neighbours' left and upper neighbour.
  void row_rays(int v, RowScratch& scratch) const {
    const std::size_t begin = row_begin[std::size_t(v)], end = row_begin[std::size_t(v) + 1];
    std::array<std::vector<double>, 3>& rays_of_row = scratch.rows[v % 3].ray;
    for (std::vector<double>& component : rays_of_row)
      if (component.size() < end - begin) component.resize(end - begin);
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3d r = ray(i);
      for (int c = 0; c < 3; ++c) rays_of_row[std::size_t(c)][i - begin] = r[c];
    }
  }

  // smoothness_row for TSA (Eq. 6), straight from the arrays (no stencil assembled), four anchors
  // per AVX instruction where the CPU has AVX (depth_terms_avx.cpp), else tsa_core per anchor: the
  // same bits either way. Row v - 1's rays must be in rows[(v - 1) % 3] (row_rays); this row's are
  // put there. An anchor without both a left and an upper neighbour has no term (zeros).
  void tsa_row(const Buffer& x, int v, RowScratch& scratch) const {
    using depth_terms::kAnchor, depth_terms::kLeft, depth_terms::kUp;
    const std::size_t begin = row_begin[std::size_t(v)], end = row_begin[std::size_t(v) + 1];
    row_rays(v, scratch);
    RowTerms& terms = scratch.rows[v % 3];
    const std::array<std::vector<double>, 3>& here = terms.ray;
    const std::array<std::vector<double>, 3>* above = v > 0 ? &scratch.rows[(v - 1) % 3].ray : nullptr;
    const std::size_t above_begin = v > 0 ? row_begin[std::size_t(v) - 1] : 0;
#if defined(PANOSCAN_DEPTH_TERMS_AVX)
    const bool quads = group_size == 4;
#else
    const bool quads = false;
#endif
    // depth[k][j] and directions[k][c][j]: stencil slot k (anchor, left, up), component c, lane j;
    // lane_out[k][j] the k-th of depth_lanes.h's eight values of lane j.
    double depth[3][4], directions[3][3][4], lane_out[8][4];
    bool complete[4];
    for (std::size_t i = begin; i < end; i += 4) {
      const std::size_t count = std::min<std::size_t>(4, end - i);
      for (std::size_t j = 0; j < 4; ++j) {
        // Lanes past the row's end repeat its last anchor; a lane without both neighbours uses the
        // anchor in their place (finite, discarded).
        const std::size_t a = i + std::min(j, count - 1);
        complete[j] = left[a] >= 0 && up[a] >= 0;
        const std::size_t l = complete[j] ? std::size_t(left[a]) : a, u = complete[j] ? std::size_t(up[a]) : a;
        const std::array<std::vector<double>, 3>& up_rays = complete[j] ? *above : here;
        const std::size_t up_at = complete[j] ? u - above_begin : a - begin;
        depth[0][j] = x[a];
        depth[1][j] = x[l];
        depth[2][j] = x[u];
        for (int c = 0; c < 3; ++c) {
          directions[0][c][j] = here[std::size_t(c)][a - begin];
          directions[1][c][j] = here[std::size_t(c)][l - begin];
          directions[2][c][j] = up_rays[std::size_t(c)][up_at];
        }
      }
#if defined(PANOSCAN_DEPTH_TERMS_AVX)
      if (quads)
        depth_terms::detail::tsa_quad_avx(depth[0], directions[0], depth[1], directions[1], depth[2], directions[2],
                                          tsa_eps, lane_out);
#endif
      if (!quads)
        for (std::size_t j = 0; j < count; ++j) {
          const auto direction = [&](int k) {
            return Eigen::Vector3d(directions[k][0][j], directions[k][1][j], directions[k][2][j]);
          };
          const depth_terms::TsaCore t = depth_terms::tsa_core(depth[0][j], direction(0), depth[1][j], direction(1),
                                                               depth[2][j], direction(2), tsa_eps);
          lane_out[0][j] = t.smoothed;
          lane_out[1][j] = t.exact;
          for (int k = 0; k < 3; ++k) {
            lane_out[2 + k][j] = t.gradient[k];
            lane_out[5 + k][j] = t.curvature[k];
          }
        }
      const int slots[3] = {kAnchor, kLeft, kUp};
      for (std::size_t j = 0; j < count; ++j) {
        const std::size_t at = i + j - begin;
        for (int k = 0; k < 3; ++k) {
          terms.gradient[std::size_t(slots[k])][at] = complete[j] ? lane_out[2 + k][j] : 0.0;
          terms.curvature[std::size_t(slots[k])][at] = complete[j] ? lane_out[5 + k][j] : 0.0;
        }
        scratch.has_smoothness[at] = complete[j];
        scratch.smoothed[at] = complete[j] ? lane_out[0][j] : 0.0;
        scratch.exact[at] = complete[j] ? lane_out[1][j] : 0.0;
      }
    }
  }

  // The smoothness terms anchored at every unknown of row v: their derivatives into rows[v % 3]
  // (by role), their values into scratch.smoothed / exact / has_smoothness. Each term is the same
  // arithmetic wherever it is computed, so an unknown whose term two blocks of evaluate() need gets
  // the same bits in both.
  void smoothness_row(const Buffer& x, int v, RowScratch& scratch) const {
    using depth_terms::kSlots;
    const std::size_t begin = row_begin[std::size_t(v)], end = row_begin[std::size_t(v) + 1];
    RowTerms& terms = scratch.rows[v % 3];
    for (int k = 0; k < kSlots; ++k)
      if (terms.gradient[std::size_t(k)].size() < end - begin) {
        terms.gradient[std::size_t(k)].resize(end - begin);
        terms.curvature[std::size_t(k)].resize(end - begin);
      }
    if (method == DepthFusionMethod::kTsa) {
      tsa_row(x, v, scratch);
      return;
    }
    for (std::size_t i = begin; i < end; ++i) {
      const depth_terms::StencilTerm term = smoothness_term(x, i);
      for (int k = 0; k < kSlots; ++k) {
        terms.gradient[std::size_t(k)][i - begin] = term.gradient[std::size_t(k)];
        terms.curvature[std::size_t(k)][i - begin] = term.curvature[std::size_t(k)];
      }
      scratch.has_smoothness[i - begin] = true;
      scratch.smoothed[i - begin] = term.smoothed;
      scratch.exact[i - begin] = term.exact;
    }
  }

  // The energy of Eq. 5 at x and, if grad, its gradient (and data_curvature). Unknowns are taken
  // in blocks of whole chunks, each block a task; the energy is summed per chunk of kChunk unknowns
  // in unknown order and the chunks' sums in chunk order, so the result does not depend on the
  // blocks or the thread count. A block streams the rows its unknowns lie in, plus the row below
  // (and for TP the row above) for the terms its last (first) row's gradients need; the terms of
  // those extra rows are computed again by the block that owns them, with the same bits.
  Parts evaluate(const Buffer& x, Buffer* grad) const {
    using depth_terms::kAnchor, depth_terms::kLeft, depth_terms::kRight, depth_terms::kUp, depth_terms::kDown;
    const std::size_t n = size();
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<Parts> partial(chunks);
    const bool all_roles = uses_right_down();
    if (grad) grad->resize(n);
    // Blocks of up to 32 chunks, at least 16 blocks where there are chunks enough: each block
    // computes about two rows' terms twice, a few per cent of the work.
    const std::size_t chunks_per_block = std::max<std::size_t>(1, std::min<std::size_t>(32, chunks / 16));
    const std::size_t blocks = (chunks + chunks_per_block - 1) / chunks_per_block;
    const int last_row = int(row_begin.size()) - 2;
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      const std::size_t own_begin = b * chunks_per_block * kChunk;
      const std::size_t own_end = std::min(n, (b + 1) * chunks_per_block * kChunk);
      RowScratch& scratch = row_scratch.local();
      if (scratch.smoothed.size() < max_row_size) {
        scratch.smoothed.resize(max_row_size);
        scratch.exact.resize(max_row_size);
        scratch.has_smoothness.resize(max_row_size);
        scratch.data.resize(max_row_size);
      }
      const int first_row = int(row[own_begin]), end_row = int(row[own_end - 1]);
      const int from = std::max(0, first_row - (all_roles ? 1 : 0)), to = std::min(last_row, end_row + 1);
      // Gradient and curvature of the owned unknowns of row v, whose neighbours' terms are all in
      // the three rows kept.
      const auto finish_row = [&](int v) {
        const std::size_t begin = std::max(own_begin, row_begin[std::size_t(v)]);
        const std::size_t end = std::min(own_end, row_begin[std::size_t(v) + 1]);
        // Row r's terms of role `slot`, indexed by unknown (rows above and below v only where they exist).
        const auto role = [&](int r, int slot, bool curvature) {
          const RowTerms& terms = scratch.rows[r % 3];
          const std::vector<double>& values =
              curvature ? terms.curvature[std::size_t(slot)] : terms.gradient[std::size_t(slot)];
          return values.data() - row_begin[std::size_t(r)];
        };
        const double *const g_anchor = role(v, kAnchor, false), *const h_anchor = role(v, kAnchor, true);
        const double *const g_left = role(v, kLeft, false), *const h_left = role(v, kLeft, true);
        const double* const g_right = all_roles ? role(v, kRight, false) : nullptr;
        const double* const h_right = all_roles ? role(v, kRight, true) : nullptr;
        const bool below = v<last_row, above = v> 0;
        const double* const g_up = below ? role(v + 1, kUp, false) : nullptr;
        const double* const h_up = below ? role(v + 1, kUp, true) : nullptr;
        const double* const g_down = all_roles && above ? role(v - 1, kDown, false) : nullptr;
        const double* const h_down = all_roles && above ? role(v - 1, kDown, true) : nullptr;
        for (std::size_t i = begin; i < end; ++i) {
          double g = g_anchor[i], h = h_anchor[i];
          if (right[i] >= 0) g += g_left[right[i]], h += h_left[right[i]];
          if (all_roles && left[i] >= 0) g += g_right[left[i]], h += h_right[left[i]];
          if (down[i] >= 0) g += g_up[down[i]], h += h_up[down[i]];
          if (all_roles && up[i] >= 0) g += g_down[up[i]], h += h_down[up[i]];
          (*grad)[i] = (*grad)[i] + lambda * g;
          data_curvature[i] += lambda * h;
        }
      };
      // TSA reads the rays of the row above the first one (row_rays keeps them for the rows after).
      if (method == DepthFusionMethod::kTsa && from > 0) row_rays(from - 1, scratch);
      std::size_t chunk = own_begin / kChunk;
      Parts sum;
      for (int v = from; v <= to; ++v) {
        smoothness_row(x, v, scratch);
        // The owned unknowns of row v: data terms (Eq. 5) a group at a time, then the energy sums
        // in unknown order, data term first, as one pass over each chunk took them.
        const std::size_t begin = std::max(own_begin, row_begin[std::size_t(v)]);
        const std::size_t end = std::min(own_end, row_begin[std::size_t(v) + 1]);
        for (std::size_t i = begin; i < end; i += group_size)
          data_terms(x, i, std::min(group_size, end - i), &scratch.data[i - row_begin[std::size_t(v)]]);
        for (std::size_t i = begin; i < end; ++i) {
          if (i / kChunk != chunk) {
            partial[chunk] = sum;
            sum = Parts{};
            chunk = i / kChunk;
          }
          const std::size_t at = i - row_begin[std::size_t(v)];
          const depth_terms::DataTerm& data = scratch.data[at];
          sum.smoothed += data.smoothed;
          sum.data += data.exact;
          if (grad) {
            (*grad)[i] = data.gradient;
            data_curvature[i] = data.curvature;
          }
          if (scratch.has_smoothness[at]) {
            sum.smoothed += lambda * scratch.smoothed[at];
            sum.smoothness += scratch.exact[at];
          }
        }
        if (grad && v - 1 >= first_row && v - 1 <= end_row) finish_row(v - 1);
      }
      if (grad && to == end_row) finish_row(end_row);  // the panorama's last row: nothing below it
      partial[chunk] = sum;
    });
    Parts total;
    for (const Parts& p : partial) {
      total.smoothed += p.smoothed;
      total.data += p.data;
      total.smoothness += p.smoothness;
    }
    return total;
  }
};

EnergyRecord record(int iteration, const DepthProblem::Parts& parts, double lambda, double data_eps) {
  EnergyRecord r;
  r.iteration = iteration;
  r.data_epsilon_m = data_eps;
  r.smoothed = parts.smoothed;
  r.data = parts.data;
  r.smoothness = parts.smoothness;
  r.smoothness_weighted = lambda * parts.smoothness;
  return r;
}

// One L-BFGS curvature pair s = x_{k+1} - x_k, y = g_{k+1} - g_k.
struct LbfgsPair {
  Buffer s, y;
  double rho = 0.0, sy = 0.0;  // rho = 1 / sy
};

// The L-BFGS vectors, kept from one continuation stage to the next (each stage starts with an
// empty memory, but its buffers are those of the stage before): at H = 1024 a stage uses up to
// sixteen 16 MB vectors, and allocating them per stage meant mapping, faulting in and filling
// about 250 MB per stage.
struct LbfgsWorkspace {
  Buffer g, g_new, x_new, direction;
  std::vector<LbfgsPair> spare;  // pairs' buffers for reuse
};

// Limited-memory BFGS (two-loop recursion) with Armijo backtracking; the smoothed energy never
// increases. Returns the energy log (iteration 0 = the start).
// One stage at the problem's current data_eps, at most max_iterations; appends to log (the start
// record only when the log is empty).
//
// Each vector update is fused with the dot product that follows it (one pass over memory instead
// of two; at H = 1024 the vectors are 16 MB each and the passes were memory-bound). Every element
// sees the same operations in the same order and every sum the same chunks in the same order as
// with separate passes (chunked_sum), so the iterates are the same bits as before the fusion.
void minimise_lbfgs(const DepthProblem& problem, Buffer& x, const FusionOptions& options, int max_iterations,
                    std::vector<EnergyRecord>& log, LbfgsWorkspace& workspace) {
  Buffer &g = workspace.g, &g_new = workspace.g_new, &x_new = workspace.x_new, &direction = workspace.direction;
  std::vector<LbfgsPair>& spare = workspace.spare;
  using Pair = LbfgsPair;
  direction.resize(x.size());
  DepthProblem::Parts parts = problem.evaluate(x, &g);
  const int first = log.empty() ? 0 : log.back().iteration;
  if (log.empty()) log.push_back(record(0, parts, problem.lambda, problem.data_eps));
  std::deque<Pair> memory;
  const std::size_t n = x.size();
  int small_steps = 0;
  std::vector<double> alpha, beta;
  // Initial inverse Hessian H0 = gamma * diag(h0): h0 the inverse of the data term's diagonal
  // curvature (plus a floor for pixels whose measurements all lie far from the current depth),
  // gamma the usual s.y / y.H0.y once curvature pairs exist. The diagonal captures the
  // ill-conditioning of the smoothed L1 term (curvature up to 1/eps per measurement), which a
  // scalar cannot. Recomputed where used rather than stored (one division against a 16 MB array).
  const auto h0 = [&](std::size_t i) { return 1.0 / (problem.data_curvature[i] + 1.0); };
  for (int iteration = first + 1; iteration <= first + max_iterations; ++iteration) {
    // Two-loop recursion: direction = -H g, computed in place in `direction` (the q of the recursion).
    Buffer& q = direction;
    const std::size_t m = memory.size();
    alpha.assign(m, 0.0);
    beta.assign(m, 0.0);
    double slope = 0.0;
    if (m == 0) {
      // q = g, q *= gamma h0 (gamma = 1), direction = -q, slope = g.direction.
      slope = chunked_sum(n, [&](std::size_t i) {
        q[i] = g[i];
        q[i] *= 1.0 * h0(i);
        q[i] = -q[i];
        return g[i] * q[i];
      });
    } else {
      // First loop, k = m-1 .. 0: alpha_k = rho_k s_k.q, q -= alpha_k y_k; the copy q = g goes with
      // the first dot product, each update with the next one.
      alpha[m - 1] = memory[m - 1].rho * chunked_sum(n, [&](std::size_t i) {
                       q[i] = g[i];
                       return memory[m - 1].s[i] * q[i];
                     });
      for (std::size_t k = m - 1; k > 0; --k) {
        const double a = alpha[k];
        const Buffer& y = memory[k].y;
        const Buffer& s_next = memory[k - 1].s;
        alpha[k - 1] = memory[k - 1].rho * chunked_sum(n, [&](std::size_t i) {
                         q[i] -= a * y[i];
                         return s_next[i] * q[i];
                       });
      }
      // The last update goes with y.H0.y of the newest pair (for gamma).
      const Buffer& y_last = memory.back().y;
      const double a0 = alpha[0];
      const Buffer& y0 = memory[0].y;
      const double yhy = chunked_sum(n, [&](std::size_t i) {
        q[i] -= a0 * y0[i];
        return y_last[i] * h0(i) * y_last[i];
      });
      const double gamma = memory.back().sy / yhy;
      // Second loop, k = 0 .. m-1: beta_k = rho_k y_k.q, q += (alpha_k - beta_k) s_k; the scaling
      // q *= gamma h0 goes with the first dot product, the last update with -q and the slope.
      beta[0] = memory[0].rho * chunked_sum(n, [&](std::size_t i) {
                  q[i] *= gamma * h0(i);
                  return memory[0].y[i] * q[i];
                });
      for (std::size_t k = 1; k < m; ++k) {
        const double c = alpha[k - 1] - beta[k - 1];
        const Buffer& s_prev = memory[k - 1].s;
        const Buffer& y = memory[k].y;
        beta[k] = memory[k].rho * chunked_sum(n, [&](std::size_t i) {
                    q[i] += c * s_prev[i];
                    return y[i] * q[i];
                  });
      }
      const double c = alpha[m - 1] - beta[m - 1];
      const Buffer& s_last = memory[m - 1].s;
      slope = chunked_sum(n, [&](std::size_t i) {
        q[i] += c * s_last[i];
        q[i] = -q[i];
        return g[i] * q[i];
      });
    }
    if (!(slope < 0)) {  // not a descent direction: restart from scaled steepest descent
      spare.insert(spare.end(), std::make_move_iterator(memory.begin()), std::make_move_iterator(memory.end()));
      memory.clear();
      double g_max = 0.0;
      for (const double v : g) g_max = std::max(g_max, std::abs(v));
      if (g_max == 0) break;
      slope = chunked_sum(n, [&](std::size_t i) {
        direction[i] = -g[i] * 1e-3 / g_max;
        return g[i] * direction[i];
      });
    }
    // Armijo backtracking.
    double step = 1.0;
    bool accepted = false;
    DepthProblem::Parts new_parts;
    x_new.resize(n);
    for (int trial = 0; trial < 40; ++trial) {
      tbb::parallel_for(std::size_t(0), n,
                        [&](std::size_t i) { x_new[i] = std::max(1e-3, x[i] + step * direction[i]); });
      // The gradient comes with the energy: most iterations accept the first trial step.
      new_parts = problem.evaluate(x_new, &g_new);
      if (new_parts.smoothed <= parts.smoothed + 1e-4 * step * slope) {
        accepted = true;
        break;
      }
      step *= 0.5;
    }
    if (!accepted) break;
    // The pair's buffers are recycled from the oldest memory slot (no allocation per iteration).
    Pair pair;
    if (!spare.empty()) {
      pair = std::move(spare.back());
      spare.pop_back();
    }
    pair.s.resize(n);
    pair.y.resize(n);
    // s, y and their three dot products in one pass.
    const std::array<double, 3> sums = chunked_sums<3>(n, [&](std::size_t i) {
      pair.s[i] = x_new[i] - x[i];
      pair.y[i] = g_new[i] - g[i];
      return std::array<double, 3>{pair.s[i] * pair.y[i], pair.s[i] * pair.s[i], pair.y[i] * pair.y[i]};
    });
    const double sy = sums[0];
    if (sy > 1e-12 * std::sqrt(sums[1] * sums[2])) {
      pair.sy = sy;
      pair.rho = 1.0 / sy;
      memory.push_back(std::move(pair));
      if (int(memory.size()) > options.lbfgs_memory) {
        spare.push_back(std::move(memory.front()));
        memory.pop_front();
      }
    } else {
      spare.push_back(std::move(pair));
    }
    const double decrease = parts.smoothed - new_parts.smoothed;
    x.swap(x_new);
    g.swap(g_new);
    parts = new_parts;
    log.push_back(record(iteration, parts, problem.lambda, problem.data_eps));
    small_steps = decrease <= options.relative_tolerance * std::abs(parts.smoothed) ? small_steps + 1 : 0;
    if (small_steps >= 3) break;
  }
  spare.insert(spare.end(), std::make_move_iterator(memory.begin()), std::make_move_iterator(memory.end()));
}

// The unknowns of Eq. 5 for fuse(): one radial depth per pixel with measurements, their
// neighbours (uncoupled across depth jumps of more than lambda_a), and the start x (the per-pixel
// median; "ERP Ave.": the mean).
void set_up(const PanoramaMeasurements& m, const FusionOptions& options, double lambda, DepthProblem& problem,
            Buffer& x) {
  const int width = m.pano.width(), height = m.pano.height;
  const std::size_t pixels = std::size_t(width) * height;
  problem.m = &m;
  problem.method = options.method;
  problem.lambda = lambda;
  problem.data_eps = options.data_epsilon_m;
  problem.tv_eps = options.tv_epsilon_m;
  problem.tsa_eps = options.tsa_epsilon_m2;
  std::vector<int> unknown_of_pixel(pixels, -1);
  for (std::size_t p = 0; p < pixels; ++p)
    if (m.count(p) > 0) {
      unknown_of_pixel[p] = int(problem.pixel.size());
      problem.pixel.push_back(p);
    }
  const std::size_t n = problem.size();
  if (n == 0) log_warn("panorama: no measurements at all; the panorama is empty");
  problem.rays = std::make_unique<const RayTable>(m.pano);
  problem.column.resize(n);
  problem.row.resize(n);
  // sin(theta) is read by the stencil terms (TV on the cylinder); TSA, evaluated from the rays
  // alone, does without (16 MB at H = 1024).
  const bool needs_sin_theta = options.method != DepthFusionMethod::kTsa;
  if (needs_sin_theta) problem.sin_theta.resize(n);
  problem.left.resize(n);
  problem.right.resize(n);
  problem.up.resize(n);
  problem.down.resize(n);
  problem.data_curvature.resize(n);  // written in full by every evaluation before it is read
  x.resize(n);                       // every element set by the loop below
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<float> radial;  // one buffer per range, not one allocation per pixel
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const std::size_t p = problem.pixel[i];
      const int u = int(p % width), v = int(p / width);
      problem.column[i] = std::uint16_t(u);  // W <= 32768 (WarpOptions::check: H <= 16384)
      problem.row[i] = std::uint16_t(v);
      if (needs_sin_theta) problem.sin_theta[i] = std::sin(M_PI * (v + 0.5) / height);
      problem.left[i] = unknown_of_pixel[std::size_t(v) * width + (u + width - 1) % width];
      problem.right[i] = unknown_of_pixel[std::size_t(v) * width + (u + 1) % width];
      problem.up[i] = v > 0 ? unknown_of_pixel[std::size_t(v - 1) * width + u] : -1;
      problem.down[i] = v + 1 < height ? unknown_of_pixel[std::size_t(v + 1) * width + u] : -1;
      // Start: the per-pixel median (minimises the L1 data term alone); "ERP Ave.": the mean.
      radial.clear();
      double sum = 0.0;
      for (std::uint64_t k = m.offsets[p]; k < m.offsets[p + 1]; ++k) {
        radial.push_back(m.samples[k].radial_m);
        sum += m.samples[k].radial_m;
      }
      if (options.method == DepthFusionMethod::kAverage) {
        x[i] = sum / double(radial.size());
      } else {
        std::nth_element(radial.begin(), radial.begin() + std::ptrdiff_t(radial.size() / 2), radial.end());
        x[i] = radial[radial.size() / 2];
      }
    }
  });
  std::vector<int>().swap(unknown_of_pixel);  // neighbours found: 8 MB off the solve
  problem.row_begin.assign(std::size_t(height) + 1, n);
  for (std::size_t i = n; i-- > 0;) problem.row_begin[problem.row[i]] = i;
  for (int v = height - 1; v >= 0; --v)  // rows without unknowns begin where the next row does
    problem.row_begin[std::size_t(v)] =
        std::min(problem.row_begin[std::size_t(v)], problem.row_begin[std::size_t(v) + 1]);
  for (int v = 0; v < height; ++v)
    problem.max_row_size =
        std::max(problem.max_row_size, problem.row_begin[std::size_t(v) + 1] - problem.row_begin[std::size_t(v)]);
  // Neighbours across a depth discontinuity are not coupled: two adjacent pixels whose starting
  // (median) depths differ by more than lambda_a belong to different surfaces, the same rule that
  // keeps the warping mesh from bridging them (§4.2). Symmetric in the pair, so left/right and
  // up/down stay consistent.
  if (options.max_coupled_depth_jump_m > 0) {
    const double jump = options.max_coupled_depth_jump_m;
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
      for (int* nb : {&problem.left[i], &problem.right[i], &problem.up[i], &problem.down[i]})
        if (*nb >= 0 && std::abs(x[i] - x[std::size_t(*nb)]) > jump) *nb = -1;
    });
  }
  if (options.method != DepthFusionMethod::kAverage && n > 0) {
    // As many zeros after the last measurement as the largest set has measurements: data_term_quad
    // loads every lane up to the longest of its four sets without a test (the values past a lane's
    // own set are masked off), so the last quad's lanes may read up to that far past the end.
    std::size_t largest_set = 0;
    for (std::size_t i = 0; i < n; ++i)
      largest_set = std::max<std::size_t>(largest_set, m.offsets[problem.pixel[i] + 1] - m.offsets[problem.pixel[i]]);
    problem.radial.resize(m.samples.size() + largest_set);
    tbb::parallel_for(std::size_t(0), m.samples.size(),
                      [&](std::size_t k) { problem.radial[k] = m.samples[k].radial_m; });
    std::fill(problem.radial.begin() + std::ptrdiff_t(m.samples.size()), problem.radial.end(), 0.0f);
  }
}

}  // namespace

const char* to_string(DepthFusionMethod method) {
  switch (method) {
    case DepthFusionMethod::kAverage: return "ave";
    case DepthFusionMethod::kTvCylindrical: return "tv";
    case DepthFusionMethod::kTvRadial: return "tv-radial";
    case DepthFusionMethod::kTsa: return "tsa";
    case DepthFusionMethod::kTp: return "tp";
  }
  return "?";
}

DepthFusionMethod depth_fusion_method_from_string(const std::string& name, const std::string& origin) {
  if (name == "ave" || name == "average") return DepthFusionMethod::kAverage;
  if (name == "tv" || name == "tv-l1") return DepthFusionMethod::kTvCylindrical;
  if (name == "tv-radial") return DepthFusionMethod::kTvRadial;
  if (name == "tsa" || name == "tsa-l1") return DepthFusionMethod::kTsa;
  if (name == "tp" || name == "tp-l1") return DepthFusionMethod::kTp;
  throw make_error(origin, "panorama.method", "unknown method '" + name + "' (ave, tv, tv-radial, tsa, tp)");
}

double FusionOptions::default_lambda(DepthFusionMethod method) {
  switch (method) {
    case DepthFusionMethod::kAverage: return 0.0;
    case DepthFusionMethod::kTvCylindrical:
    case DepthFusionMethod::kTvRadial: return 50.0;
    case DepthFusionMethod::kTsa: return 5e3;
    case DepthFusionMethod::kTp: return 2e8;
  }
  return 0.0;
}

double FusionOptions::effective_lambda(int height, double mean_count) const {
  if (lambda >= 0) return lambda;
  // The balance data / (lambda * smoothness) per pixel goes as mean_count * H^k / lambda (README,
  // "lambda_b"): the data term sums one residual per measurement, and the smoothness term shrinks as
  // (pixel spacing)^k, k = 1 (TV: one length along the surface), 2 (TSA: an area; TP: two lengths
  // along the surface times two noise offsets across it). Keeping the paper's balance means scaling
  // its lambda by both.
  const double resolution = double(height) / double(lambda_reference_height);
  const double count = mean_count > 0 ? mean_count / lambda_reference_count : 1.0;
  switch (method) {
    case DepthFusionMethod::kAverage: return 0.0;
    case DepthFusionMethod::kTvCylindrical:
    case DepthFusionMethod::kTvRadial: return lambda_scale * default_lambda(method) * resolution * count;
    case DepthFusionMethod::kTsa:
    case DepthFusionMethod::kTp: return lambda_scale * default_lambda(method) * resolution * resolution * count;
  }
  return 0.0;
}

void FusionOptions::check(const std::string& origin) const {
  if (!std::isfinite(lambda)) throw make_error(origin, "panorama.lambda", "not finite");
  if (iterations < 0 || iterations > 100000) throw make_error(origin, "panorama.iterations", "must be in [0, 100000]");
  if (lbfgs_memory < 1 || lbfgs_memory > 50) throw make_error(origin, "panorama.lbfgs_memory", "must be in [1, 50]");
  if (!(data_epsilon_m > 0)) throw make_error(origin, "panorama.data_epsilon_m", "must be > 0");
  if (!(data_epsilon_final_m > 0) || data_epsilon_final_m > data_epsilon_m)
    throw make_error(origin, "panorama.data_epsilon_final_m", "must be > 0 and at most panorama.data_epsilon_m");
  if (!(tv_epsilon_m > 0) || !(tsa_epsilon_m2 > 0)) throw make_error(origin, "panorama.epsilon", "must be > 0");
  if (!(relative_tolerance >= 0)) throw make_error(origin, "panorama.tolerance", "must be >= 0");
  if (!(max_coupled_depth_jump_m >= 0)) throw make_error(origin, "panorama.max_coupled_depth_jump_m", "must be >= 0");
  if (!(max_sigma_m > 0)) throw make_error(origin, "panorama.max_sigma_m", "must be > 0");
  if (!(lambda_reference_count > 0) || !std::isfinite(lambda_reference_count))
    throw make_error(origin, "panorama.lambda_reference_count", "must be > 0");
  if (!(lambda_scale >= 0) || !std::isfinite(lambda_scale))
    throw make_error(origin, "panorama.lambda_scale", "must be >= 0");
  if (lambda_reference_height < 1) throw make_error(origin, "panorama.lambda_reference_height", "must be >= 1");
}

namespace {

// The mean number of measurements per pixel that has any (FusionOptions::effective_lambda's count),
// after checking that the CSR offsets fit the panorama.
double checked_mean_count(const PanoramaMeasurements& m) {
  const std::size_t pixels = std::size_t(m.pano.width()) * m.pano.height;
  if (m.offsets.size() != pixels + 1 || m.offsets.back() != m.samples.size())
    throw make_error("measurements", "offsets", "do not match the panorama size");
  std::size_t measured = 0;
  for (std::size_t p = 0; p < pixels; ++p) measured += m.count(p) > 0;
  return measured > 0 ? double(m.samples.size()) / double(measured) : 0.0;
}

}  // namespace

Panorama fuse(const PanoramaMeasurements& m, const FusionOptions& options) {
  options.check();
  const int width = m.pano.width(), height = m.pano.height;
  Panorama out;
  out.pano = m.pano;
  out.world_from_pano = m.world_from_pano;
  out.method = to_string(options.method);
  out.mean_count = checked_mean_count(m);
  out.lambda = options.effective_lambda(height, out.mean_count);

  DepthProblem problem;
  Buffer x;
  set_up(m, options, out.lambda, problem, x);
  const std::size_t n = problem.size();
  if (options.method != DepthFusionMethod::kAverage && n > 0) {
    // Continuation in the data term's smoothing: a wide eps first (well conditioned: moves the
    // pixels that need to move), then eps / 5 per stage down to data_epsilon_final_m, so that the
    // final solve is close to the exact L1 of Eq. 5 (whose energy is the one reported). Each
    // stage gets an equal share of the iteration budget and stops early when converged.
    std::vector<double> stages;
    for (double eps = options.data_epsilon_m;; eps /= 5) {
      stages.push_back(std::max(eps, options.data_epsilon_final_m));
      if (eps <= options.data_epsilon_final_m) break;
    }
    int budget = options.iterations;
    LbfgsWorkspace workspace;
    for (std::size_t k = 0; k < stages.size(); ++k) {
      problem.data_eps = stages[k];
      const int share = budget / int(stages.size() - k);
      const std::size_t before = out.energy.size();
      minimise_lbfgs(problem, x, options, share, out.energy, workspace);
      budget -= int(out.energy.size() - std::max<std::size_t>(before, 1));
    }
    UninitialisedVector<float>().swap(problem.radial);
    const EnergyRecord& first = out.energy.front();
    const EnergyRecord& last = out.energy.back();
    std::ostringstream msg;
    msg << "panorama " << out.method << " (lambda " << out.lambda << "): " << out.energy.size() - 1
        << " iterations, energy " << first.total() << " -> " << last.total() << " (data " << last.data
        << ", lambda*smoothness " << last.smoothness_weighted << ", ratio "
        << (last.smoothness_weighted > 0 ? last.data / last.smoothness_weighted : 0.0) << ")";
    log_info(msg.str());
  }
  // Colour mean, variance about the solved depth, count, flag. (The images are allocated only now,
  // after the solve: 50 MB at H = 1024 off the peak.)
  out.colour = ImageF32(width, height, 3, 0.f);
  out.depth = ImageF32(width, height, 1, 0.f);
  out.variance = ImageF32(width, height, 1, 0.f);
  out.count = ImageF32(width, height, 1, 0.f);
  out.flagged = ImageU8(width, height, 1, 0);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    const std::size_t p = problem.pixel[i];
    const int u = int(p % width), v = int(p / width);
    double rgb[3] = {0, 0, 0}, sq = 0.0;
    for (std::uint64_t k = m.offsets[p]; k < m.offsets[p + 1]; ++k) {
      const PanoramaMeasurement& s = m.samples[k];
      for (int c = 0; c < 3; ++c) rgb[c] += s.rgb[c];
      const double r = double(s.radial_m) - x[i];
      sq += r * r;
    }
    const double count = double(m.count(p));
    for (int c = 0; c < 3; ++c) out.colour.at(u, v, c) = float(rgb[c] / count / 255.0);
    out.depth.at(u, v) = float(x[i]);
    out.variance.at(u, v) = float(sq / count);
    out.count.at(u, v) = float(count);
    out.flagged.at(u, v) = std::sqrt(sq / count) > options.max_sigma_m ? 1 : 0;
  });
  return out;
}

namespace detail {

DepthEnergy depth_energy(const PanoramaMeasurements& m, const FusionOptions& options, const std::vector<double>& x) {
  options.check();
  if (options.method == DepthFusionMethod::kAverage)
    throw make_error("depth_energy", "panorama.method", "'ave' has no energy to minimise");
  DepthProblem problem;
  Buffer start;
  set_up(m, options, options.effective_lambda(m.pano.height, checked_mean_count(m)), problem, start);
  if (!x.empty() && x.size() != start.size())
    throw make_error("depth_energy", "x", fmt::format("{} unknowns expected, {} given", start.size(), x.size()));
  const Buffer at = x.empty() ? start : Buffer(x.begin(), x.end());
  Buffer gradient;
  DepthEnergy out;
  out.smoothed = problem.evaluate(at, &gradient).smoothed;
  out.x.assign(at.begin(), at.end());
  out.gradient.assign(gradient.begin(), gradient.end());
  return out;
}

}  // namespace detail
}  // namespace panoscan
