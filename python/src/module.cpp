// The Python module `panoscan` (pybind11): the testbed from a notebook. A thin layer, as the
// program is: it converts arguments, calls the libraries and converts results; no algorithm lives
// here. panoscan::Error becomes panoscan.Error (a RuntimeError) with the program's one-line
// message; the GIL is released around every call into the libraries that reads files, simulates,
// tracks, fuses or registers. Config keys are the program's (`config={"noise.preset": "kinect"}`).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "panoscan/core/cloud_file.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/cloud_evaluation.h"
#include "panoscan/eval/trajectory_metrics.h"
#include "panoscan/recon/cloud_registration.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/poses.h"
#include "panoscan/recon/stage2.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/scene_loader.h"
#include "panoscan/sim/simulator.h"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace panoscan::python {
namespace {

using Matrix4 = py::array_t<double>;

// ---- conversions ---------------------------------------------------------------------------------

Matrix4 to_numpy(const Rigid3d& pose) {
  Matrix4 out({4, 4});
  auto m = out.mutable_unchecked<2>();
  const Eigen::Matrix4d matrix = pose.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = matrix(r, c);
  return out;
}

// A 4x4 rigid transform from numpy; Error naming `what` when it is not one.
Rigid3d rigid_from_numpy(const py::handle& object, const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw make_error(what, "", "expected a 4x4 array (a rigid transform)");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = a.at(r, c);
  const Eigen::Matrix3d rotation = m.block<3, 3>(0, 0);
  if (!m.allFinite() || (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      rotation.determinant() < 0 || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
    throw make_error(what, "", "not a rigid transform (rotation within 1e-6, last row 0 0 0 1)");
  return make_rigid(rotation, m.block<3, 1>(0, 3));
}

template <typename T>
py::array_t<T> image_to_numpy(const Image<T>& image) {
  std::vector<py::ssize_t> shape{image.height, image.width};
  if (image.channels > 1) shape.push_back(image.channels);
  py::array_t<T> out(shape);
  std::copy(image.data.begin(), image.data.end(), out.mutable_data());
  return out;
}

// N x 3 float64 array -> points; Error naming `what` for another shape or a non-finite value.
std::vector<Eigen::Vector3d> points_from_numpy(const py::handle& object, const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!a || a.ndim() != 2 || a.shape(1) != 3) throw make_error(what, "", "expected an N x 3 array of points");
  std::vector<Eigen::Vector3d> points(std::size_t(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    points[i] = Eigen::Vector3d(a.at(i, 0), a.at(i, 1), a.at(i, 2));
    if (!points[i].allFinite()) throw make_error(what, "row " + std::to_string(i), "is not finite");
  }
  return points;
}

// {"key": value} -> the program's overrides (values as YAML scalars: 1, 0.5, true, "kinect").
Config config_from_dict(const std::optional<py::dict>& config) {
  Config out;
  if (!config) return out;
  for (const auto& [key, value] : *config) {
    std::string text;
    if (py::isinstance<py::bool_>(value))
      text = value.cast<bool>() ? "true" : "false";
    else if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
      text = "[";
      for (const auto& item : value) text += (text.size() > 1 ? ", " : "") + std::string(py::str(item));
      text += "]";
    } else
      text = std::string(py::str(value));
    out.set(key.cast<std::string>(), text);
  }
  return out;
}

py::object json_to_python(const std::string& json_text) {
  return py::module_::import("json").attr("loads")(json_text);
}

std::vector<StampedPose> trajectory_from(const py::handle& object, const std::string& what) {
  if (py::isinstance<py::str>(object) || py::hasattr(object, "__fspath__"))
    return read_tum_trajectory(py::str(object).cast<std::string>());
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!a || a.ndim() != 2 || a.shape(1) != 8)
    throw make_error(what, "", "expected a TUM file path or an N x 8 array (t tx ty tz qx qy qz qw)");
  std::vector<StampedPose> poses;
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const Eigen::Quaterniond q(a.at(i, 7), a.at(i, 4), a.at(i, 5), a.at(i, 6));
    if (!(q.norm() > 0.5)) throw make_error(what, "row " + std::to_string(i), "quaternion is not unit");
    poses.push_back({a.at(i, 0), make_rigid(q.normalized(), Eigen::Vector3d(a.at(i, 1), a.at(i, 2), a.at(i, 3)))});
  }
  return poses;
}

py::array_t<double> trajectory_to_numpy(const std::vector<StampedPose>& poses) {
  py::array_t<double> out({py::ssize_t(poses.size()), py::ssize_t(8)});
  auto m = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Quaterniond q(poses[i].world_from_cam.linear());
    const Eigen::Vector3d& t = poses[i].world_from_cam.translation();
    const double row[8] = {poses[i].timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    for (int c = 0; c < 8; ++c) m(i, c) = row[c];
  }
  return out;
}

// ---- scans ---------------------------------------------------------------------------------------

// One frame: its images are read when asked for (a scan holds thousands).
struct Frame {
  std::shared_ptr<const ScanIndex> scan;
  int sensor = 0;
  std::size_t index = 0;
  double timestamp() const { return scan->frames[sensor][index].timestamp; }
  fs::path rgb_path() const { return scan->root / scan->rig.sensors[sensor].name / scan->frames[sensor][index].rgb_file; }
  fs::path depth_path() const {
    return scan->root / scan->rig.sensors[sensor].name / scan->frames[sensor][index].depth_file;
  }
  RgbdFrame load() const {
    py::gil_scoped_release release;
    return load_frame(*scan, sensor, index);
  }
};

struct Scan {
  std::shared_ptr<const ScanIndex> index;
};

// rig.json's content (core's rig_to_json, one definition of the fields), each ref_from_cam as a 4x4 array.
py::dict rig_dict(const RigInfo& rig) {
  py::dict out = py::dict(py::module_::import("json").attr("loads")(rig_to_json(rig)));
  py::list sensors = out["sensors"];
  for (std::size_t k = 0; k < rig.sensors.size(); ++k)
    sensors[k]["ref_from_cam"] = to_numpy(rig.sensors[k].ref_from_cam);
  return out;
}

// ---- panoramas -----------------------------------------------------------------------------------

py::dict panorama_dict(const Panorama& p) {
  py::dict out;
  out["colour"] = image_to_numpy(p.colour);
  out["depth"] = image_to_numpy(p.depth);
  out["variance"] = image_to_numpy(p.variance);
  out["count"] = image_to_numpy(p.count);
  out["world_from_pano"] = to_numpy(p.world_from_pano);
  out["height"] = p.pano.height;
  out["method"] = p.method;
  out["lambda"] = p.lambda;
  return out;
}

// The figures of one registration, for both kinds of input.
void add_registration(py::dict& out, const Rigid3d& target_from_source, const IcpResult& icp, double overlap,
                      const std::string& method_used) {
  out["target_from_source"] = to_numpy(target_from_source);
  out["overlap"] = overlap;
  out["iterations"] = icp.iterations;
  out["converged"] = icp.converged;
  out["fitness"] = icp.fitness;
  out["rmse_m"] = icp.rmse_m;
  out["method_used"] = method_used;
}

// ---- the functions -------------------------------------------------------------------------------

Scan read_scan(const fs::path& dir) {
  py::gil_scoped_release release;
  return Scan{std::make_shared<const ScanIndex>(read_scan_index(dir))};
}

py::dict read_panorama_py(const fs::path& dir) {
  Panorama panorama;
  {
    py::gil_scoped_release release;
    panorama = read_panorama(dir);
  }
  return panorama_dict(panorama);
}

std::string simulate(const std::string& scene_name, const std::string& position, const fs::path& out,
                     const std::optional<py::dict>& config, const std::optional<std::string>& resolution,
                     std::optional<int> every, std::optional<int> frames, std::optional<long long> seed,
                     const std::optional<std::string>& noise, std::optional<int> threads, bool overwrite) {
  Config c = config_from_dict(config);
  if (resolution) {
    int width = 0, height = 0;
    char separator = 0;
    if (std::sscanf(resolution->c_str(), "%d%c%d", &width, &separator, &height) != 3 || separator != 'x')
      throw make_error("resolution", "", "expected 'WIDTHxHEIGHT', got '" + *resolution + "'");
    c.set("camera.width", std::to_string(width));
    c.set("camera.height", std::to_string(height));
  }
  if (every) c.set("output.every", std::to_string(*every));
  if (frames) c.set("output.frames", std::to_string(*frames));
  if (seed) c.set("seed", std::to_string(*seed));
  if (noise) c.set("noise.preset", *noise);
  if (threads) c.set("threads", std::to_string(*threads));
  const SimOptions options = sim_options_from_config(c);
  const bool style_given = c.has("scene.texture");
  const scenes::SceneStyle style = scenes::scene_style_from_config(c);
  c.check_all_used();
  py::gil_scoped_release release;
  const Scene scene = load_scene(scene_name, style, style_given);
  int index = -1;
  for (std::size_t i = 0; i < scene.positions.size(); ++i)
    if (scene.positions[i].name == position) index = int(i);
  if (index < 0) {
    try {
      std::size_t used = 0;
      index = std::stoi(position, &used) - 1;
      if (used != position.size()) index = -1;
    } catch (const std::exception&) {
    }
  }
  if (index < 0) throw make_error("position", "", "'" + position + "' is neither a 1-based index nor a position name");
  Simulator(scene, index, options).write_scan(out, overwrite);
  return out.string();
}

py::dict track(const fs::path& scan_dir, const std::optional<fs::path>& out, const std::string& mode,
               const std::optional<py::dict>& config, int threads, bool allow_unreliable, bool overwrite) {
  Config c = config_from_dict(config);
  c.set("track.mode", mode);
  c.set("threads", std::to_string(threads));
  if (allow_unreliable) c.set("track.allow_unreliable", "true");
  const TrackingOptions options = tracking_options_from_config(c);
  c.check_all_used();
  if (out && fs::exists(*out) && !overwrite)
    throw make_error(out->string(), "", "already exists (overwrite=True to replace it)");
  TrackingResult result;
  ScanIndex scan;
  {
    py::gil_scoped_release release;
    scan = read_scan_index(scan_dir);
    result = track_scan(scan, options);
    if (out) write_tracking_result(*out, result, scan.rig);
    require_reliable_tracking(result, options, scan_dir.string());
  }
  py::dict trajectories;
  for (std::size_t s = 0; s < scan.rig.sensors.size(); ++s)
    trajectories[py::str(scan.rig.sensors[s].name)] = trajectory_to_numpy(result.trajectory.world_from_cam[s]);
  py::list extrinsics;
  for (const Rigid3d& pose : result.trajectory.ref_from_cam) extrinsics.append(to_numpy(pose));
  py::dict d = py::dict(json_to_python(tracking_stats_json(result, scan.rig)));
  d["trajectories"] = trajectories;
  d["ref_from_cam"] = extrinsics;
  d["world_from_axis"] = to_numpy(result.trajectory.world_from_axis);
  d["reliable"] = result.verdict.reliable;
  return d;
}

py::dict build_panorama_py(const fs::path& scan_dir, const std::string& poses, const std::optional<fs::path>& out,
                           const std::optional<std::string>& method, std::optional<int> height,
                           const std::optional<py::dict>& config, int threads, bool overwrite) {
  Config c = config_from_dict(config);
  if (method) c.set("panorama.method", *method);
  if (height) c.set("panorama.height", std::to_string(*height));
  c.set("threads", std::to_string(threads));
  const PanoramaOptions options = panorama_options_from_config(c);
  const TrackingOptions tracking = tracking_options_from_config(c);
  c.check_all_used();
  PanoramaResult result;
  {
    py::gil_scoped_release release;
    const ScanIndex scan = read_scan_index(scan_dir);
    const RigTrajectory trajectory = scan_poses(poses, scan_dir, scan, tracking);
    result = build_panorama(scan, trajectory, options);
    if (out) write_panorama(*out, result.panorama, overwrite);
  }
  return panorama_dict(result.panorama);
}

py::dict register_py(const py::object& source, const py::object& target, const std::string& method,
                     const py::object& initial, const std::optional<py::dict>& config, int threads) {
  Config c = config_from_dict(config);
  c.set("registration.method", method);
  c.set("threads", std::to_string(threads));
  std::optional<Rigid3d> initial_pose;
  if (!initial.is_none()) initial_pose = rigid_from_numpy(initial, "initial");
  const bool arrays = !py::isinstance<py::str>(source) && !py::hasattr(source, "__fspath__");
  if (arrays != (!py::isinstance<py::str>(target) && !py::hasattr(target, "__fspath__")))
    throw make_error("source", "", "source and target must both be panorama folders or both N x 3 arrays");
  py::dict out;
  if (arrays) {
    // Point arrays: the point-cloud path of `recon register` (no images, so no ORB guess).
    const CloudRegistrationOptions options = cloud_registration_options_from_config(c);
    c.check_all_used();
    CloudFile a, b;
    a.path = "source";
    b.path = "target";
    a.format = b.format = "numpy";
    a.points = points_from_numpy(source, "source");
    b.points = points_from_numpy(target, "target");
    a.declared_points = a.points.size();
    b.declared_points = b.points.size();
    CloudPairRegistration r;
    {
      py::gil_scoped_release release;
      r = register_cloud_files(a, b, initial_pose.value_or(Rigid3d::Identity()), options);
    }
    add_registration(out, r.target_from_source, r.icp, r.overlap, to_string(r.method_used));
    out["covariance"] = r.covariance_note;
    return out;
  }
  const PairRegistrationOptions options = pair_registration_options_from_config(c);
  c.check_all_used();
  const std::string source_dir = py::str(source), target_dir = py::str(target);
  PairRegistration r;
  {
    py::gil_scoped_release release;
    const Panorama s = read_panorama(source_dir), t = read_panorama(target_dir);
    r = register_panorama_pair(s, t, options, initial_pose ? &*initial_pose : nullptr, source_dir, target_dir);
  }
  add_registration(out, r.target_from_source, r.icp, r.overlap, to_string(options.icp.method));
  out["orb_inliers"] = r.guess.inliers;
  out["consistent_matches"] = r.consistent_matches;
  return out;
}

py::dict eval_cloud(const py::object& cloud, const fs::path& mesh, const std::optional<py::dict>& config,
                    int threads) {
  Config c = config_from_dict(config);
  eval::CloudEvalOptions options = eval::cloud_eval_options_from_config(c);
  c.check_all_used();
  options.threads = threads;
  eval::CloudEvalReport report;
  if (py::isinstance<py::str>(cloud) || py::hasattr(cloud, "__fspath__")) {
    const std::string path = py::str(cloud);
    py::gil_scoped_release release;
    report = eval::evaluate_cloud_files(mesh, path, options);
  } else {
    PointCloud points;
    points.positions = points_from_numpy(cloud, "cloud");
    py::gil_scoped_release release;
    report = eval::evaluate_cloud_points(mesh, std::move(points), "<array>", options);
  }
  py::dict d = py::dict(json_to_python(eval::cloud_report_to_json(report)));
  // The headline figures at the top level, in millimetres.
  const py::dict accuracy = py::dict(d["accuracy"]);
  for (const char* key : {"rmse_mm", "mean_mm", "median_mm", "p90_mm", "max_mm"})
    if (accuracy.contains(key)) d[key] = accuracy[key];
  return d;
}

py::dict eval_traj(const py::object& gt, const py::object& est, double rpe_delta_s, bool align) {
  eval::TrajectoryMetricsOptions options;
  options.rpe_delta_s = rpe_delta_s;
  options.align = align;
  options.check("eval_traj");
  const std::vector<StampedPose> gt_poses = trajectory_from(gt, "gt"), est_poses = trajectory_from(est, "est");
  eval::TrajectoryMetrics m;
  {
    py::gil_scoped_release release;
    m = eval::evaluate_trajectory(gt_poses, est_poses, options, "gt", "est");
  }
  auto stats = [](const eval::ErrorStats& s, double scale) {
    py::dict d;
    d["count"] = s.count;
    d["rmse"] = s.rmse * scale;
    d["mean"] = s.mean * scale;
    d["median"] = s.median * scale;
    d["p90"] = s.p90 * scale;
    d["max"] = s.max * scale;
    return d;
  };
  py::dict d;
  d["matched_poses"] = m.matched_poses;
  d["ate_mm"] = stats(m.ate_m, 1e3);
  d["ate_rotation_deg"] = stats(m.ate_rotation_deg, 1.0);
  d["rpe_translation_mm"] = stats(m.rpe_translation_m, 1e3);
  d["rpe_rotation_deg"] = stats(m.rpe_rotation_deg, 1.0);
  d["rpe_delta_s"] = m.rpe_delta_s;
  d["gt_from_est"] = to_numpy(m.gt_from_est);
  d["ate_rmse_mm"] = m.ate_m.rmse * 1e3;
  return d;
}

}  // namespace
}  // namespace panoscan::python

PYBIND11_MODULE(panoscan, m) {
  using namespace panoscan;
  using namespace panoscan::python;
  namespace py = pybind11;
  m.doc() = "PanoScan: panoramic RGB-D scanning with unsynchronized cameras (Yang et al., TOG 2020), from Python";
  m.attr("__version__") = project_version();
  m.attr("source_revision") = source_revision();
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      error(e.what());
    }
  });

  py::class_<Frame>(m, "Frame", "one RGB-D frame of a scan; its images are read when asked for")
      .def_property_readonly("timestamp", &Frame::timestamp)
      .def_property_readonly("sensor", [](const Frame& f) { return f.sensor; })
      .def_property_readonly("rgb_path", &Frame::rgb_path)
      .def_property_readonly("depth_path", &Frame::depth_path)
      .def_property_readonly(
          "rgb", [](const Frame& f) { return image_to_numpy(f.load().rgb); }, "H x W x 3 uint8")
      .def_property_readonly(
          "depth", [](const Frame& f) { return image_to_numpy(f.load().depth); }, "H x W float32, metres, 0 = invalid")
      .def("__repr__", [](const Frame& f) {
        return "<panoscan.Frame " + f.scan->rig.sensors[f.sensor].name + " t=" + format_timestamp(f.timestamp()) + ">";
      });

  py::class_<Scan>(m, "Scan", "a scan folder: rig.json and the frames of each sensor")
      .def_property_readonly("root", [](const Scan& s) { return s.index->root; })
      .def_property_readonly("rig", [](const Scan& s) { return rig_dict(s.index->rig); })
      .def_property_readonly("sensors",
                             [](const Scan& s) {
                               std::vector<std::string> names;
                               for (const auto& sensor : s.index->rig.sensors) names.push_back(sensor.name);
                               return names;
                             })
      .def_property_readonly(
          "frames",
          [](const Scan& s) {
            std::vector<std::vector<Frame>> frames(s.index->frames.size());
            for (std::size_t k = 0; k < frames.size(); ++k)
              for (std::size_t f = 0; f < s.index->frames[k].size(); ++f) frames[k].push_back({s.index, int(k), f});
            return frames;
          },
          "per sensor, the frames in timestamp order")
      .def("__repr__", [](const Scan& s) {
        std::size_t frames = 0;
        for (const auto& f : s.index->frames) frames += f.size();
        return "<panoscan.Scan " + s.index->root.string() + ": " + std::to_string(s.index->rig.sensors.size()) +
               " sensors, " + std::to_string(frames) + " frames>";
      });

  m.def("read_scan", &read_scan, py::arg("dir"), "Reads and validates a scan folder (rig.json, listings).");
  m.def("read_panorama", &read_panorama_py, py::arg("dir"),
        "A panorama folder as numpy arrays: colour (H x 2H x 3), depth, variance, count (H x 2H), world_from_pano.");
  m.def("simulate", &simulate, py::arg("scene"), py::arg("position") = "1", py::kw_only(), py::arg("out"),
        py::arg("config") = py::none(), py::arg("resolution") = py::none(), py::arg("every") = py::none(),
        py::arg("frames") = py::none(), py::arg("seed") = py::none(), py::arg("noise") = py::none(),
        py::arg("threads") = py::none(), py::arg("overwrite") = false,
        "Simulates one scanning position (a built-in scene name or a mesh file) into `out`; returns its path.");
  m.def("track", &track, py::arg("scan_dir"), py::kw_only(), py::arg("out") = py::none(), py::arg("mode") = "full",
        py::arg("config") = py::none(), py::arg("threads") = 0, py::arg("allow_unreliable") = false,
        py::arg("overwrite") = false,
        "Joint tracking (paper 4.1): the stats, the verdict and per camera an N x 8 TUM trajectory array. "
        "Raises panoscan.Error for an unreliable result unless allow_unreliable.");
  m.def("build_panorama", &build_panorama_py, py::arg("scan_dir"), py::kw_only(), py::arg("poses") = "ground-truth",
        py::arg("out") = py::none(), py::arg("method") = py::none(), py::arg("height") = py::none(),
        py::arg("config") = py::none(), py::arg("threads") = 0, py::arg("overwrite") = false,
        "An RGB-D panorama with per-pixel variance (paper 4.2); poses: ground-truth, tracked or a track folder.");
  m.def("register", &register_py, py::arg("source"), py::arg("target"), py::kw_only(), py::arg("method") = "gicp-ours",
        py::arg("initial") = py::none(), py::arg("config") = py::none(), py::arg("threads") = 0,
        "Registers source onto target: two panorama folders, or two N x 3 point arrays; target_from_source 4x4.");
  m.def("eval_cloud", &eval_cloud, py::arg("cloud"), py::arg("mesh"), py::kw_only(), py::arg("config") = py::none(),
        py::arg("threads") = 0,
        "Exact distances of a cloud (a PLY path or an N x 3 array) to a mesh (PLY path): rmse_mm, mean_mm, ...");
  m.def("eval_traj", &eval_traj, py::arg("gt"), py::arg("est"), py::kw_only(), py::arg("rpe_delta_s") = 1.0,
        py::arg("align") = true,
        "ATE and RPE of an estimated trajectory (a TUM path or an N x 8 array) against the ground truth.");
}
