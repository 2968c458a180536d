// The factors of the joint tracking (paper §4.1, Eq. 1-3) as Ceres auto-differentiated cost
// functors. Internal to panoscan_recon_tracking.
//
// Parameter blocks: a pose is a unit quaternion in Ceres order (w, x, y, z) on
// ceres::QuaternionManifold plus a translation; poses are world_from_cam (T_ci), world_from_axis
// (T_u) and ref_from_cam (T_c). The azimuth alpha is one unwrapped real number.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace panoscan::tracking_factors {

// (q1, t1) * (q2, t2)
template <typename T>
void compose(const T* q1, const T* t1, const T* q2, const T* t2, T* q, T* t) {
  ceres::QuaternionProduct(q1, q2, q);
  ceres::QuaternionRotatePoint(q1, t2, t);
  for (int k = 0; k < 3; ++k) t[k] += t1[k];
}

template <typename T>
void invert(const T* q, const T* t, T* q_inv, T* t_inv) {
  q_inv[0] = q[0];
  q_inv[1] = -q[1];
  q_inv[2] = -q[2];
  q_inv[3] = -q[3];
  ceres::QuaternionRotatePoint(q_inv, t, t_inv);
  for (int k = 0; k < 3; ++k) t_inv[k] = -t_inv[k];
}

// Eq. 1: observation of landmark y_j in frame ci. The measurement p = d [u, v, 1] has the covariance
// J diag(s_u^2, s_v^2, s_d^2) J^T with J = d p / d(u, v, d) = [[d, 0, u], [0, d, v], [0, 0, 1]]; the
// whitened residual is diag(s_u, s_v, s_d)^-1 J^-1 (p - K X), X = T_ci^-1 y_j, which is
//   ((d u - (fx X + cx Z)) - u (d - Z)) / (d s_u),  likewise for v,  (d - Z) / s_d.
// It is linear in X (no division by the predicted depth), so it stays finite for points behind
// the camera during the first iterations.
struct ObservationCost {
  ObservationCost(double u, double v, double d, double fx, double fy, double cx, double cy, double sigma_px,
                  double sigma_d)
      : u_(u), v_(v), d_(d), fx_(fx), fy_(fy), cx_(cx), cy_(cy), sigma_px_(sigma_px), sigma_d_(sigma_d) {}

  template <typename T>
  bool operator()(const T* q_world_from_cam, const T* t_world_from_cam, const T* point_in_world, T* residual) const {
    const T q_cam_from_world[4] = {q_world_from_cam[0], -q_world_from_cam[1], -q_world_from_cam[2],
                                   -q_world_from_cam[3]};
    const T offset[3] = {point_in_world[0] - t_world_from_cam[0], point_in_world[1] - t_world_from_cam[1],
                         point_in_world[2] - t_world_from_cam[2]};
    T point_in_cam[3];
    ceres::QuaternionRotatePoint(q_cam_from_world, offset, point_in_cam);
    const T& x = point_in_cam[0];
    const T& y = point_in_cam[1];
    const T& z = point_in_cam[2];
    const T e_d = d_ - z;
    const T e_u = d_ * u_ - (fx_ * x + cx_ * z);
    const T e_v = d_ * v_ - (fy_ * y + cy_ * z);
    residual[0] = (e_u - u_ * e_d) / (d_ * sigma_px_);
    residual[1] = (e_v - v_ * e_d) / (d_ * sigma_px_);
    residual[2] = e_d / sigma_d_;
    return true;
  }

  // The graph's factor: ObservationJacobian below (the same residual with closed-form Jacobians).
  static ceres::CostFunction* create(double u, double v, double d, double fx, double fy, double cx, double cy,
                                     double sigma_px, double sigma_d);
  // This functor auto-differentiated: the reference the closed form is tested against.
  static ceres::CostFunction* create_autodiff(double u, double v, double d, double fx, double fy, double cx, double cy,
                                              double sigma_px, double sigma_d) {
    return new ceres::AutoDiffCostFunction<ObservationCost, 3, 4, 3, 3>(
        new ObservationCost(u, v, d, fx, fy, cx, cy, sigma_px, sigma_d));
  }

  double u_, v_, d_, fx_, fy_, cx_, cy_, sigma_px_, sigma_d_;
};

// Eq. 1 with closed-form Jacobians. The observation factors are most of the graph's residual
// blocks, and auto-differentiating them with 10-dimensional jets was the largest part of the
// Jacobian evaluation (issue 20, tracking solve). The residual above is affine in the camera-frame
// point: r = W X + c with X = R^T (y - t), R = R(q) (world_from_cam),
//   W = [[-fx, 0, u - cx] / (d s_u), [0, -fy, v - cy] / (d s_v), [0, 0, -1] / s_d],  c = (0, 0, d / s_d),
// so dr/dy = W R^T and dr/dt = -W R^T. For the rotation: Ceres' QuaternionManifold perturbs on the
// left, q' = [cos|δ|, sin|δ| δ/|δ|] q, i.e. R' = Exp(2δ) R, hence X' = X + 2 R^T [y - t]x δ and the
// tangent Jacobian is M = 2 W R^T [y - t]x. Ceres asks for the ambient 3x4 Jacobian J and forms
// J P with P = PlusJacobian(q) (4x3, P^T P = |q|^2 I); J = M P^T / |q|^2 gives J P = M.
class ObservationJacobian final : public ceres::SizedCostFunction<3, 4, 3, 3> {
 public:
  ObservationJacobian(double u, double v, double d, double fx, double fy, double cx, double cy, double sigma_px,
                      double sigma_d)
      : w00_(-fx / (d * sigma_px)),
        w02_((u - cx) / (d * sigma_px)),
        w11_(-fy / (d * sigma_px)),
        w12_((v - cy) / (d * sigma_px)),
        w22_(-1.0 / sigma_d),
        c2_(d / sigma_d) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* q = parameters[0];
    const double* t = parameters[1];
    const double* y = parameters[2];
    // R(q) of the normalised quaternion, as ceres::QuaternionRotatePoint uses it.
    const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    const double s = 2.0 / n2;
    const double xx = q[1] * q[1], yy = q[2] * q[2], zz = q[3] * q[3];
    const double wx = q[0] * q[1], wy = q[0] * q[2], wz = q[0] * q[3];
    const double xy = q[1] * q[2], xz = q[1] * q[3], yz = q[2] * q[3];
    double R[3][3] = {{1.0 - s * (yy + zz), s * (xy - wz), s * (xz + wy)},
                      {s * (xy + wz), 1.0 - s * (xx + zz), s * (yz - wx)},
                      {s * (xz - wy), s * (yz + wx), 1.0 - s * (xx + yy)}};
    const double o[3] = {y[0] - t[0], y[1] - t[1], y[2] - t[2]};
    double X[3];
    for (int k = 0; k < 3; ++k) X[k] = R[0][k] * o[0] + R[1][k] * o[1] + R[2][k] * o[2];  // R^T o
    residuals[0] = w00_ * X[0] + w02_ * X[2];
    residuals[1] = w11_ * X[1] + w12_ * X[2];
    residuals[2] = w22_ * X[2] + c2_;
    if (!jacobians) return true;
    // A = W R^T (row k of R^T is column k of R).
    double A[3][3];
    for (int c = 0; c < 3; ++c) {
      A[0][c] = w00_ * R[c][0] + w02_ * R[c][2];
      A[1][c] = w11_ * R[c][1] + w12_ * R[c][2];
      A[2][c] = w22_ * R[c][2];
    }
    if (jacobians[2])
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) jacobians[2][3 * r + c] = A[r][c];
    if (jacobians[1])
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) jacobians[1][3 * r + c] = -A[r][c];
    if (jacobians[0]) {
      // M = 2 A [o]x, [o]x = [[0, -o2, o1], [o2, 0, -o0], [-o1, o0, 0]]; divided by |q|^2 here
      // because P^T P = |q|^2 I (the block is unit up to rounding).
      double M[3][3];
      for (int r = 0; r < 3; ++r) {
        M[r][0] = s * (A[r][1] * o[2] - A[r][2] * o[1]);
        M[r][1] = s * (A[r][2] * o[0] - A[r][0] * o[2]);
        M[r][2] = s * (A[r][0] * o[1] - A[r][1] * o[0]);
      }
      // P^T (3x4) of QuaternionManifold::PlusJacobian at q = (w, x, y, z):
      //   P = [[-x, -y, -z], [w, z, -y], [-z, w, x], [y, -x, w]].
      const double P[4][3] = {{-q[1], -q[2], -q[3]}, {q[0], q[3], -q[2]}, {-q[3], q[0], q[1]}, {q[2], -q[1], q[0]}};
      for (int r = 0; r < 3; ++r)
        for (int a = 0; a < 4; ++a) jacobians[0][4 * r + a] = M[r][0] * P[a][0] + M[r][1] * P[a][1] + M[r][2] * P[a][2];
    }
    return true;
  }

 private:
  double w00_, w02_, w11_, w12_, w22_, c2_;
};

inline ceres::CostFunction* ObservationCost::create(double u, double v, double d, double fx, double fy, double cx,
                                                    double cy, double sigma_px, double sigma_d) {
  return new ObservationJacobian(u, v, d, fx, fy, cx, cy, sigma_px, sigma_d);
}

// Eq. 2: pose regularisation. E = T_ci^-1 * T_u * R(alpha_ci) * T_u^-1 * T_r * T_c, residual =
// (translation(E) / sigma_t, rotation_vector(E) / sigma_r) (the linearisation of E into 6 numbers).
// T_r (world_from_rig) is the reference camera's pose at alpha = 0 without wobble: the paper's
// Eq. 2 has T_r = I, i.e. the rig frame is the fixed first frame of the reference camera, wobble
// included; see tracking.h for why it is a free variable here.
struct RegularisationCost {
  RegularisationCost(double sigma_t, double sigma_r) : sigma_t_(sigma_t), sigma_r_(sigma_r) {}

  template <typename T>
  bool operator()(const T* q_world_from_cam, const T* t_world_from_cam, const T* alpha, const T* q_world_from_axis,
                  const T* t_world_from_axis, const T* q_world_from_rig, const T* t_world_from_rig,
                  const T* q_ref_from_cam, const T* t_ref_from_cam, T* residual) const {
    const T half = alpha[0] * T(0.5);
    const T q_rotation[4] = {cos(half), T(0), T(0), sin(half)};
    const T t_zero[3] = {T(0), T(0), T(0)};
    T q_axis_from_world[4], t_axis_from_world[3];
    invert(q_world_from_axis, t_world_from_axis, q_axis_from_world, t_axis_from_world);
    T q_a[4], t_a[3], q_b[4], t_b[3], q_r[4], t_r[3], q_c[4], t_c[3];
    compose(q_world_from_axis, t_world_from_axis, q_rotation, t_zero, q_a, t_a);  // T_u R(alpha)
    compose(q_a, t_a, q_axis_from_world, t_axis_from_world, q_b, t_b);            // ... T_u^-1
    compose(q_b, t_b, q_world_from_rig, t_world_from_rig, q_r, t_r);              // ... T_r
    compose(q_r, t_r, q_ref_from_cam, t_ref_from_cam, q_c, t_c);                  // ... T_c (expected world_from_cam)
    T q_cam_from_world[4], t_cam_from_world[3];
    invert(q_world_from_cam, t_world_from_cam, q_cam_from_world, t_cam_from_world);
    T q_error[4], t_error[3];
    compose(q_cam_from_world, t_cam_from_world, q_c, t_c, q_error, t_error);
    T rotation_vector[3];
    ceres::QuaternionToAngleAxis(q_error, rotation_vector);
    for (int k = 0; k < 3; ++k) {
      residual[k] = t_error[k] / sigma_t_;
      residual[3 + k] = rotation_vector[k] / sigma_r_;
    }
    return true;
  }

  static ceres::CostFunction* create(double sigma_t, double sigma_r) {
    return new ceres::AutoDiffCostFunction<RegularisationCost, 6, 4, 3, 1, 4, 3, 4, 3, 4, 3>(
        new RegularisationCost(sigma_t, sigma_r));
  }

  double sigma_t_, sigma_r_;
};

// The rig's wobble is shared (beyond the paper): W = (T_u R(alpha) T_u^-1 T_r)^-1 T_ci T_c^-1 is the
// rig's deviation from the rigid rotation at the time of frame ci (in the rig frame). Two frames of
// different cameras taken dt apart see nearly the same W; residual = (translation, rotation vector)
// of W_a^-1 W_b over (sigma_t, sigma_r), the wobble's change over dt. It ties each T_c to the
// reference camera in all six directions, which Eq. 2 with independent deviations cannot.
struct SharedWobbleCost {
  SharedWobbleCost(double sigma_t, double sigma_r) : sigma_t_(sigma_t), sigma_r_(sigma_r) {}

  // world_from_rig as the frame sees it (T_ci T_c^-1) and as the model has it (T_u R T_u^-1 T_r):
  // returns rig_model_from_rig_actual.
  template <typename T>
  static void wobble(const T* q_cam, const T* t_cam, const T* alpha, const T* q_axis, const T* t_axis, const T* q_rig,
                     const T* t_rig, const T* q_extr, const T* t_extr, T* q_out, T* t_out) {
    const T half = alpha[0] * T(0.5);
    const T q_rotation[4] = {cos(half), T(0), T(0), sin(half)};
    const T t_zero[3] = {T(0), T(0), T(0)};
    T q_axis_inv[4], t_axis_inv[3], q_a[4], t_a[3], q_b[4], t_b[3], q_m[4], t_m[3];
    invert(q_axis, t_axis, q_axis_inv, t_axis_inv);
    compose(q_axis, t_axis, q_rotation, t_zero, q_a, t_a);
    compose(q_a, t_a, q_axis_inv, t_axis_inv, q_b, t_b);
    compose(q_b, t_b, q_rig, t_rig, q_m, t_m);  // model world_from_rig
    T q_extr_inv[4], t_extr_inv[3], q_actual[4], t_actual[3], q_m_inv[4], t_m_inv[3];
    invert(q_extr, t_extr, q_extr_inv, t_extr_inv);
    compose(q_cam, t_cam, q_extr_inv, t_extr_inv, q_actual, t_actual);  // actual world_from_rig
    invert(q_m, t_m, q_m_inv, t_m_inv);
    compose(q_m_inv, t_m_inv, q_actual, t_actual, q_out, t_out);
  }

  template <typename T>
  bool operator()(const T* q_cam_a, const T* t_cam_a, const T* alpha_a, const T* q_extr_a, const T* t_extr_a,
                  const T* q_cam_b, const T* t_cam_b, const T* alpha_b, const T* q_extr_b, const T* t_extr_b,
                  const T* q_axis, const T* t_axis, const T* q_rig, const T* t_rig, T* residual) const {
    T q_wa[4], t_wa[3], q_wb[4], t_wb[3], q_wa_inv[4], t_wa_inv[3], q_e[4], t_e[3];
    wobble(q_cam_a, t_cam_a, alpha_a, q_axis, t_axis, q_rig, t_rig, q_extr_a, t_extr_a, q_wa, t_wa);
    wobble(q_cam_b, t_cam_b, alpha_b, q_axis, t_axis, q_rig, t_rig, q_extr_b, t_extr_b, q_wb, t_wb);
    invert(q_wa, t_wa, q_wa_inv, t_wa_inv);
    compose(q_wa_inv, t_wa_inv, q_wb, t_wb, q_e, t_e);
    T rotation_vector[3];
    ceres::QuaternionToAngleAxis(q_e, rotation_vector);
    for (int k = 0; k < 3; ++k) {
      residual[k] = t_e[k] / sigma_t_;
      residual[3 + k] = rotation_vector[k] / sigma_r_;
    }
    return true;
  }

  static ceres::CostFunction* create(double sigma_t, double sigma_r) {
    return new ceres::AutoDiffCostFunction<SharedWobbleCost, 6, 4, 3, 1, 4, 3, 4, 3, 1, 4, 3, 4, 3, 4, 3>(
        new SharedWobbleCost(sigma_t, sigma_r));
  }

  double sigma_t_, sigma_r_;
};

// The calibration along the two directions of T_c that no factor observes without cross-camera
// landmarks (rotation about and sliding along the axis, expressed in the rig frame): residual =
// (axis . translation(prior^-1 T_c) / sigma_t, axis . rotation_vector(prior^-1 T_c) / sigma_r),
// axis = R_r^T R_u e_z (the rotation axis in the reference camera's frame). sigma_r = 0 leaves the
// rotation free (its residual 0): the slide alone held (TrackingOptions::hold_extrinsics_slide).
struct ExtrinsicsNullPriorCost {
  ExtrinsicsNullPriorCost(const double* q_prior, const double* t_prior, double sigma_t, double sigma_r)
      : sigma_t_(sigma_t), sigma_r_(sigma_r) {
    for (int k = 0; k < 4; ++k) q_prior_inverse_[k] = k == 0 ? q_prior[0] : -q_prior[k];
    for (int k = 0; k < 3; ++k) t_prior_[k] = t_prior[k];
  }
  template <typename T>
  bool operator()(const T* q, const T* t, const T* q_axis, const T* q_rig, T* residual) const {
    const T q_inv[4] = {T(q_prior_inverse_[0]), T(q_prior_inverse_[1]), T(q_prior_inverse_[2]), T(q_prior_inverse_[3])};
    T q_error[4], rotation_vector[3];
    ceres::QuaternionProduct(q_inv, q, q_error);
    ceres::QuaternionToAngleAxis(q_error, rotation_vector);
    const T z[3] = {T(0), T(0), T(1)};
    T axis_world[3], axis_rig[3];
    ceres::QuaternionRotatePoint(q_axis, z, axis_world);
    const T q_rig_inv[4] = {q_rig[0], -q_rig[1], -q_rig[2], -q_rig[3]};
    ceres::QuaternionRotatePoint(q_rig_inv, axis_world, axis_rig);
    T along_t = T(0), along_r = T(0);
    for (int k = 0; k < 3; ++k) {
      along_t += axis_rig[k] * (t[k] - T(t_prior_[k]));
      along_r += axis_rig[k] * rotation_vector[k];
    }
    residual[0] = along_t / sigma_t_;
    residual[1] = sigma_r_ > 0.0 ? along_r / sigma_r_ : T(0);
    return true;
  }
  static ceres::CostFunction* create(const double* q_prior, const double* t_prior, double sigma_t, double sigma_r) {
    return new ceres::AutoDiffCostFunction<ExtrinsicsNullPriorCost, 2, 4, 3, 4, 4>(
        new ExtrinsicsNullPriorCost(q_prior, t_prior, sigma_t, sigma_r));
  }
  double q_prior_inverse_[4], t_prior_[3], sigma_t_, sigma_r_;
};

// Eq. 3: velocity smoothness between three consecutive azimuth nodes (timestamp order, all
// cameras): v_{i,j} = (alpha_i - alpha_j) / (t_i - t_j); residual (v_{i,i+1} - v_{i-1,i}) / sigma.
// Linear, so its Jacobian is constant.
struct VelocityCost {
  VelocityCost(double t_prev, double t_mid, double t_next, double sigma)
      : dt_before_(t_mid - t_prev), dt_after_(t_next - t_mid), sigma_(sigma) {}

  template <typename T>
  bool operator()(const T* alpha_prev, const T* alpha_mid, const T* alpha_next, T* residual) const {
    residual[0] = ((alpha_next[0] - alpha_mid[0]) / dt_after_ - (alpha_mid[0] - alpha_prev[0]) / dt_before_) / sigma_;
    return true;
  }

  static ceres::CostFunction* create(double t_prev, double t_mid, double t_next, double sigma) {
    return new ceres::AutoDiffCostFunction<VelocityCost, 1, 1, 1, 1>(new VelocityCost(t_prev, t_mid, t_next, sigma));
  }

  double dt_before_, dt_after_, sigma_;
};

// Frames (of different cameras) taken at the same instant share the azimuth: (alpha_a - alpha_b) / sigma.
struct SameTimeCost {
  explicit SameTimeCost(double sigma) : sigma_(sigma) {}
  template <typename T>
  bool operator()(const T* alpha_a, const T* alpha_b, T* residual) const {
    residual[0] = (alpha_a[0] - alpha_b[0]) / sigma_;
    return true;
  }
  static ceres::CostFunction* create(double sigma) {
    return new ceres::AutoDiffCostFunction<SameTimeCost, 1, 1, 1>(new SameTimeCost(sigma));
  }
  double sigma_;
};

// Prior on a pose: (translation difference / sigma_t, rotation vector of prior^-1 * pose / sigma_r).
// Used weakly on T_u to fix its gauge (rotation about and translation along its own z axis, which
// cancel in T_u R(alpha) T_u^-1) and on T_c (the calibration) for the same two directions of each
// camera, which only cross-camera landmarks observe.
struct PosePriorCost {
  PosePriorCost(const double* q_prior, const double* t_prior, double sigma_t, double sigma_r)
      : sigma_t_(sigma_t), sigma_r_(sigma_r) {
    for (int k = 0; k < 4; ++k) q_prior_inverse_[k] = k == 0 ? q_prior[0] : -q_prior[k];
    for (int k = 0; k < 3; ++k) t_prior_[k] = t_prior[k];
  }
  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const T q_inv[4] = {T(q_prior_inverse_[0]), T(q_prior_inverse_[1]), T(q_prior_inverse_[2]), T(q_prior_inverse_[3])};
    T q_error[4], rotation_vector[3];
    ceres::QuaternionProduct(q_inv, q, q_error);
    ceres::QuaternionToAngleAxis(q_error, rotation_vector);
    for (int k = 0; k < 3; ++k) {
      residual[k] = (t[k] - t_prior_[k]) / sigma_t_;
      residual[3 + k] = rotation_vector[k] / sigma_r_;
    }
    return true;
  }
  static ceres::CostFunction* create(const double* q_prior, const double* t_prior, double sigma_t, double sigma_r) {
    return new ceres::AutoDiffCostFunction<PosePriorCost, 6, 4, 3>(
        new PosePriorCost(q_prior, t_prior, sigma_t, sigma_r));
  }
  double q_prior_inverse_[4], t_prior_[3], sigma_t_, sigma_r_;
};

// Depth odometry (beyond the paper; track.depth_odometry, depth_odometry.h): frames a and b of one
// camera and the ICP's measured a_from_b = Z. The error transform E = Z^-1 T_a^-1 T_b is the
// identity when the poses agree with the measurement; the residual is S (rotation vector of E,
// translation of E), S^T S the ICP's information in that (omega, v) order (a right perturbation of
// Z, as the ICP linearises). Directions the depth does not observe (a wall's in-plane slide) have
// zero rows in S and no effect.
struct RelativePoseCost {
  RelativePoseCost(const double* q_measured, const double* t_measured, const double* sqrt_information_row_major) {
    for (int k = 0; k < 4; ++k) q_measured_inverse_[k] = k == 0 ? q_measured[0] : -q_measured[k];
    for (int k = 0; k < 3; ++k) t_measured_[k] = t_measured[k];
    for (int k = 0; k < 36; ++k) sqrt_information_[k] = sqrt_information_row_major[k];
  }
  template <typename T>
  bool operator()(const T* q_a, const T* t_a, const T* q_b, const T* t_b, T* residual) const {
    T q_a_inv[4], t_a_inv[3], q_ab[4], t_ab[3];
    invert(q_a, t_a, q_a_inv, t_a_inv);
    compose(q_a_inv, t_a_inv, q_b, t_b, q_ab, t_ab);  // T_a^-1 T_b
    const T q_z_inv[4] = {T(q_measured_inverse_[0]), T(q_measured_inverse_[1]), T(q_measured_inverse_[2]),
                          T(q_measured_inverse_[3])};
    T q_error[4], error[6], shifted[3];
    ceres::QuaternionProduct(q_z_inv, q_ab, q_error);
    ceres::QuaternionToAngleAxis(q_error, error);
    for (int k = 0; k < 3; ++k) shifted[k] = t_ab[k] - T(t_measured_[k]);
    ceres::QuaternionRotatePoint(q_z_inv, shifted, error + 3);  // R_z^T (t_ab - t_z)
    for (int r = 0; r < 6; ++r) {
      residual[r] = T(0);
      for (int c = 0; c < 6; ++c) residual[r] += T(sqrt_information_[6 * r + c]) * error[c];
    }
    return true;
  }
  static ceres::CostFunction* create(const double* q_measured, const double* t_measured,
                                     const double* sqrt_information_row_major) {
    return new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
        new RelativePoseCost(q_measured, t_measured, sqrt_information_row_major));
  }
  double q_measured_inverse_[4], t_measured_[3], sqrt_information_[36];
};

}  // namespace panoscan::tracking_factors
