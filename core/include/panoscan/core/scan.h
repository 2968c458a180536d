// The scan format (docs/ARCHITECTURE.md §5): one directory per scanning position.
//
//   rig.json                   format name + version, sensors (intrinsics, image size, depth scale,
//                              calibrated extrinsics ref_from_cam), reference sensor index, motion
//   import.json                only in scans made by `panoscan import` (tum_import.h): provenance
//   camK/rgb/<ts>.png          8-bit colour, registered to depth
//   camK/depth/<ts>.png        16-bit depth, z along the optical axis, depth_scale units per metre (5000)
//   camK/rgb.txt, depth.txt    TUM listings "timestamp filename" (filename relative to camK/)
//   groundtruth/               only for eval and tests (written by the simulator)
//     camK.txt                 TUM trajectory, world_from_camera in the scene frame
//     rig_truth.json           true extrinsics, axis pose, noise settings, seed
//     mesh.ply                 ground-truth mesh in the scene frame
//     depth_clean/camK/<ts>.png  noiseless depth (optional)
//     normals/camK/<ts>.exr      unit normal of the hit triangle in camera K's frame (optional)
//     ids/camK/<ts>.exr          hit triangle and its material, 32-bit (optional)
//
// The reader validates everything a reconstruction relies on and throws Error naming the file
// and the field; the writer builds the directory atomically.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/mesh.h"
#include "panoscan/core/trajectory.h"

namespace panoscan {

constexpr const char* kScanFormatName = "panoscan-scan";
constexpr int kScanFormatVersion = 1;

struct SensorInfo {
  std::string name;  // "cam0", also the sub-directory name
  PinholeIntrinsics intrinsics;
  double depth_scale = 5000.0;  // PNG units per metre
  double nominal_fps = 30.0;
  // Calibrated extrinsics: pose of this camera in the reference camera's frame (T_c in the
  // paper). Identity for the reference camera. In simulated scans these carry the configured
  // calibration error; the truth is in groundtruth/rig_truth.json.
  Rigid3d ref_from_cam = Rigid3d::Identity();
};

// How the rig moved while it recorded (rig.json "motion", optional, default rotator): on the
// in-place rotator the method is made for (every simulated scan), or by hand (the usual TUM RGB-D
// sequence; `import tum` writes handheld by default).
enum class RigMotion { kRotator, kHandheld };
const char* to_string(RigMotion motion);  // "rotator", "handheld"
// Throws Error naming `origin` and `field` for anything but "rotator" or "handheld".
RigMotion rig_motion_from_string(const std::string& text, const std::string& origin, const std::string& field);

struct RigInfo {
  std::vector<SensorInfo> sensors;
  int reference_sensor = 0;
  std::string description;  // free text (e.g. "simulated: office SO-1")
  RigMotion motion = RigMotion::kRotator;
};

struct FrameEntry {
  double timestamp = 0.0;
  std::string rgb_file;    // relative to the camera directory, e.g. "rgb/1.000000.png"
  std::string depth_file;  // relative to the camera directory
};

struct ScanIndex {
  std::filesystem::path root;
  RigInfo rig;
  std::vector<std::vector<FrameEntry>> frames;  // per sensor, in timestamp order
};

struct RgbdFrame {
  double timestamp = 0.0;
  ImageU8 rgb;     // 3 channels
  ImageF32 depth;  // metres, 0 = invalid
};

// Reads and validates rig.json and the listings (entries present in both listings with equal
// timestamps, strictly increasing, files exist). Does not read the images.
ScanIndex read_scan_index(const std::filesystem::path& scan_dir);
// Reads one frame and validates its image sizes against the rig.
RgbdFrame load_frame(const ScanIndex& scan, int sensor, std::size_t frame_index);

// rig.json <-> RigInfo (exposed for tests and tools).
std::string rig_to_json(const RigInfo& rig);
RigInfo rig_from_json(const std::string& text, const std::string& origin);

// Ground-truth files written beside a scan.
std::filesystem::path groundtruth_dir(const std::filesystem::path& scan_dir);
std::vector<StampedPose> read_groundtruth_trajectory(const std::filesystem::path& scan_dir, int sensor);

// Per-frame ground truth of the noiseless ray (simulator options output.normals, output.ids), one
// value per pixel of camera `sensor`'s frame at `timestamp` (the listing's timestamp):
// - normals: 3 channels (EXR float channels R, G, B = x, y, z of the camera frame: x right, y down,
//   z forward): the hit triangle's geometric unit normal turned to face the camera (its dot product
//   with the pixel's ray is negative); 0, 0, 0 where the ray hits nothing.
// - ids: 2 channels (EXR 32-bit UINT channels triangle_id, material_id, each int32 by its bit
//   pattern): channel 0 the index of the hit triangle in groundtruth/mesh.ply (the scene mesh),
//   channel 1 its material's index in the scene's material list (materials are shared by every
//   object made of them: a material or class id, not an instance id); -1 (4294967295 in the file)
//   where nothing is hit, and material -1 for a mesh without materials.
// Unlike depth_clean they are not limited to the depth sensor's range. The readers check the size
// against rig.json (and ids >= -1) and throw Error naming the file.
std::filesystem::path groundtruth_normals_path(const std::filesystem::path& scan_dir, const std::string& sensor_name,
                                               double timestamp);
std::filesystem::path groundtruth_ids_path(const std::filesystem::path& scan_dir, const std::string& sensor_name,
                                           double timestamp);
ImageF32 read_groundtruth_normals(const ScanIndex& scan, int sensor, double timestamp);
ImageI32 read_groundtruth_ids(const ScanIndex& scan, int sensor, double timestamp);

// Writes a scan directory atomically: everything goes into a temporary sibling directory,
// and commit() writes listings and rig.json and renames it into place. Frames of different
// sensors may be written concurrently; frames of one sensor must arrive in timestamp order.
class ScanWriter {
 public:
  ScanWriter(const std::filesystem::path& scan_dir, const RigInfo& rig, bool overwrite, int png_compression = 1);
  ~ScanWriter();

  void write_frame(int sensor, double timestamp, const ImageU8& rgb, const ImageU16& depth);
  // write_frame for images already encoded (encode_png of the colour, encode_png16 of the depth,
  // image_io.h), so that a caller can encode frames in parallel and write them in time order. The
  // PNG headers are checked against the sensor's image size and sample format.
  void write_encoded_frame(int sensor, double timestamp, const std::string& rgb_png, const std::string& depth_png);
  // A frame whose images exist as files already (an import): copied, or hard-linked, into place
  // under the names write_frame gives (the colour file keeps its extension). The caller checks
  // their contents (sizes, 8-bit colour, 16-bit depth); the same ordering rule as write_frame.
  enum class FileTransfer { kCopy, kHardLink };
  void add_frame_files(int sensor, double timestamp, const std::filesystem::path& rgb_file,
                       const std::filesystem::path& depth_file, FileTransfer transfer);
  void write_clean_depth(int sensor, double timestamp, const ImageU16& depth);
  // The per-frame ground truth described at groundtruth_normals_path: `normal_cam` 3 channels,
  // `triangle_id` and `material_id` 1 channel each, all of the sensor's image size.
  void write_groundtruth_normals(int sensor, double timestamp, const ImageF32& normal_cam);
  void write_groundtruth_ids(int sensor, double timestamp, const ImageI32& triangle_id, const ImageI32& material_id);
  void write_groundtruth_trajectory(int sensor, const std::vector<StampedPose>& poses);
  void write_groundtruth_file(const std::string& name, const std::string& bytes);  // e.g. rig_truth.json
  void write_groundtruth_mesh(const TriangleMesh& mesh);
  // Path inside the temporary directory (for writers that produce files themselves).
  std::filesystem::path temp_path(const std::string& relative) const;
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Metres -> depth PNG units with rounding; 0 stays 0; values beyond the 16-bit range become 0.
ImageU16 depth_to_png_units(const ImageF32& depth_m, double depth_scale);
ImageF32 depth_from_png_units(const ImageU16& depth, double depth_scale);

}  // namespace panoscan
