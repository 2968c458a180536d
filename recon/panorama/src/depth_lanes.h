// Private to panoscan_recon_panorama: the TSA term's arithmetic (Eq. 6 at one pixel, see
// depth_terms.h tsa_core) written once for a lane type V that is a double or a GCC vector of
// doubles (__m256d), so that the scalar tsa_core and the four-pixel tsa_quad_avx are the same
// operations lane for lane and agree bit for bit. The operations are in Eigen's order for the
// expressions tsa_core was first written in (a cross product component by component, a dot
// product or squared norm summed x, y, z from the left), so the values are also those of that
// Eigen code.
//
// Deliberately in an anonymous namespace: depth_solver.cpp (baseline x86-64) and
// depth_terms_avx.cpp (compiled with -mavx) each get their own copy compiled for their own
// instruction set; shared inline definitions would let the linker pick the AVX copy for everyone.
// For the same reason nothing here calls the standard library or Eigen.
#pragma once

namespace panoscan::depth_terms {
namespace {
namespace lanes {

template <typename V>
struct Vec3 {
  V x, y, z;
};

template <typename V>
inline Vec3<V> cross(const Vec3<V>& a, const Vec3<V>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

template <typename V>
inline V dot(const Vec3<V>& a, const Vec3<V>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

// The TSA term's value and derivatives (depth_terms.h TsaCore) at an anchor with depth dp along
// ray rp, its left neighbour (dl, rl) and its upper neighbour (du, ru). out: smoothed, exact,
// gradient (anchor, left, up), curvature (anchor, left, up).
template <typename V, typename Sqrt>
inline void tsa_lanes(V dp, const Vec3<V>& rp, V dl, const Vec3<V>& rl, V du, const Vec3<V>& ru, V eps,
                      const Sqrt& sqrt_lanes, V out[8]) {
  const Vec3<V> pi{dp * rp.x, dp * rp.y, dp * rp.z};
  const Vec3<V> a{pi.x - dl * rl.x, pi.y - dl * rl.y, pi.z - dl * rl.z};
  const Vec3<V> b{pi.x - du * ru.x, pi.y - du * ru.y, pi.z - du * ru.z};
  const Vec3<V> c = cross(a, b);
  const V norm2 = dot(c, c);
  const V s = sqrt_lanes(norm2 + eps * eps);
  // One division, six products: the divider bounds this loop (session 53; six divisions before).
  const V inverse = 1.0 / s;
  const Vec3<V> g{c.x * inverse, c.y * inverse, c.z * inverse};
  const Vec3<V> grad_a = cross(b, g), grad_b = cross(g, a);
  out[0] = s - eps;
  out[1] = sqrt_lanes(norm2);
  out[2] = dot(Vec3<V>{grad_a.x + grad_b.x, grad_a.y + grad_b.y, grad_a.z + grad_b.z}, rp);
  out[3] = -dot(grad_a, rl);
  out[4] = -dot(grad_b, ru);
  const Vec3<V> k0 = cross(rp, Vec3<V>{b.x - a.x, b.y - a.y, b.z - a.z}), k1 = cross(rl, b), k2 = cross(ru, a);
  out[5] = dot(k0, k0) * inverse;
  out[6] = dot(k1, k1) * inverse;
  out[7] = dot(k2, k2) * inverse;
}

}  // namespace lanes
}  // namespace
}  // namespace panoscan::depth_terms
