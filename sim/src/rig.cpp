#include "panoscan/sim/rig.h"

#include <algorithm>
#include <numeric>

#include "panoscan/core/random.h"

namespace panoscan {

namespace {

// Camera looking along the bracket's x axis, pitched up by `pitch` (OpenCV axes: x right, y down).
Eigen::Matrix3d bracket_from_cam_rotation(double pitch) {
  const Eigen::Vector3d z_cam(std::cos(pitch), 0.0, std::sin(pitch));
  const Eigen::Vector3d x_cam(0.0, -1.0, 0.0);
  const Eigen::Vector3d y_cam = z_cam.cross(x_cam);
  Eigen::Matrix3d r;
  r.col(0) = x_cam;
  r.col(1) = y_cam;
  r.col(2) = z_cam;
  return r;
}

Eigen::Vector3d random_unit_vector(RandomStream& rng) {
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
  } while (v.norm() < 1e-6);
  return v.normalized();
}

}  // namespace

std::vector<std::pair<int, int>> RigModel::vertical_neighbours() const {
  std::vector<int> order(pitches_rad.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return pitches_rad[a] < pitches_rad[b]; });
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 1; i < order.size(); ++i) {
    // Views overlap when the pitch step is not larger than the vertical field of view.
    if (pitches_rad[order[i]] - pitches_rad[order[i - 1]] <= intrinsics.fov_y() + 1e-9)
      pairs.emplace_back(order[i - 1], order[i]);
  }
  return pairs;
}

RigModel make_rig(const RigOptions& options, std::uint64_t seed) {
  RigModel rig;
  rig.intrinsics = PinholeIntrinsics::primesense(options.width, options.height);
  rig.intrinsics.fx = options.focal_px * options.width / 640.0;
  rig.intrinsics.fy = rig.intrinsics.fx;  // square pixels
  rig.reference_sensor = options.reference_sensor;

  const auto& rpy = options.install_rpy_deg;
  const Eigen::Matrix3d install_rotation = (Eigen::AngleAxisd(deg2rad(rpy[2]), Eigen::Vector3d::UnitZ()) *
                                            Eigen::AngleAxisd(deg2rad(rpy[1]), Eigen::Vector3d::UnitY()) *
                                            Eigen::AngleAxisd(deg2rad(rpy[0]), Eigen::Vector3d::UnitX()))
                                               .toRotationMatrix();
  rig.axis_from_bracket = make_rigid(
      install_rotation,
      Eigen::Vector3d(options.install_offset_m[0], options.install_offset_m[1], options.install_offset_m[2]));
  const int n = static_cast<int>(options.pitches_deg.size());
  const double middle = 0.5 * (n - 1);
  for (int c = 0; c < n; ++c) {
    const double pitch = deg2rad(options.pitches_deg[c]);
    rig.pitches_rad.push_back(pitch);
    // Stacked vertically, highest pitch on top, centred on the bracket origin.
    const double height = options.camera_spacing_m * (middle - c);  // camera 0 on top
    rig.bracket_from_cam.push_back(
        make_rigid(bracket_from_cam_rotation(pitch), Eigen::Vector3d(options.camera_forward_m, 0.0, height)));
  }
  const Rigid3d bracket_from_ref = rig.bracket_from_cam[rig.reference_sensor];
  for (int c = 0; c < n; ++c) {
    const Rigid3d ref_from_cam = bracket_from_ref.inverse() * rig.bracket_from_cam[c];
    rig.ref_from_cam_true.push_back(ref_from_cam);
    if (c == rig.reference_sensor) {
      rig.ref_from_cam_calibrated.push_back(Rigid3d::Identity());
      continue;
    }
    // A calibration error of exactly the configured size in a random direction.
    RandomStream rng(seed, c, 0, RandomPurpose::kExtrinsicsError);
    const Eigen::Vector3d rotation_error = random_unit_vector(rng) * deg2rad(options.calibration_error_deg);
    const Eigen::Vector3d translation_error = random_unit_vector(rng) * options.calibration_error_m;
    const Rigid3d error = make_rigid(so3_exp(rotation_error), translation_error);
    rig.ref_from_cam_calibrated.push_back(ref_from_cam * error);
  }
  return rig;
}

}  // namespace panoscan
