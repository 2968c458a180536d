// A panorama on disk (what stage 2 reads): float EXRs, PNG previews, the cloud and panorama.json.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/version.h"
#include "panoscan/core/error.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/image_io.h"
#include "panoscan/recon/panorama.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
constexpr const char* kPanoramaFormat = "panoscan-panorama";
constexpr int kPanoramaVersion = 1;

// A small perceptual-ish colour map (dark blue -> cyan -> yellow -> red), t in [0, 1].
void colour_map(double t, std::uint8_t* rgb) {
  t = std::clamp(t, 0.0, 1.0);
  static const double stops[5][3] = {
      {0.05, 0.05, 0.35}, {0.0, 0.55, 0.85}, {0.3, 0.85, 0.4}, {0.98, 0.85, 0.1}, {0.8, 0.05, 0.05}};
  const double s = t * 4.0;
  const int i = std::min(3, int(s));
  const double f = s - i;
  for (int c = 0; c < 3; ++c) rgb[c] = std::uint8_t(std::lround(255.0 * ((1 - f) * stops[i][c] + f * stops[i + 1][c])));
}

// Colour-mapped preview with a legend under the image: a colour bar (low value left, high right)
// with five ticks labelled in `unit` (values times unit_scale), and the quantity's name.
ImageU8 preview(const ImageF32& values, const ImageF32& count, double low, double high, const std::string& name,
                const std::string& unit, double unit_scale) {
  const int width = values.width;
  const double font = std::clamp(width / 1600.0, 0.3, 1.2);
  const int text_height = int(std::ceil(22 * font)) + 4;
  const int bar = std::max(4, values.height / 24);
  const int legend = bar + 2 * text_height + 4;
  ImageU8 out(width, values.height + legend, 3, 0);
  for (int v = 0; v < values.height; ++v)
    for (int u = 0; u < width; ++u)
      if (count.at(u, v) > 0) colour_map((values.at(u, v) - low) / std::max(1e-12, high - low), &out.at(u, v, 0));
  const int bar_top = values.height + 2;
  for (int v = bar_top; v < bar_top + bar; ++v)
    for (int u = 0; u < width; ++u) colour_map(double(u) / std::max(1, width - 1), &out.at(u, v, 0));
  // Text with OpenCV on the same buffer (interleaved RGB rows).
  cv::Mat canvas(out.height, out.width, CV_8UC3, out.data.data());
  const cv::Scalar white(255, 255, 255);
  const int thickness = std::max(1, int(std::lround(font * 1.5)));
  const int ticks = 4;
  for (int k = 0; k <= ticks; ++k) {
    const double t = double(k) / ticks;
    const int x = std::min(width - 1, int(std::lround(t * (width - 1))));
    cv::line(canvas, {x, bar_top}, {x, bar_top + bar + 3}, white, 1);
    const std::string label = fmt::format("{:.3g}", (low + t * (high - low)) * unit_scale);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, thickness, &baseline);
    const int left = std::clamp(x - size.width / 2, 0, std::max(0, width - size.width));
    cv::putText(canvas, label, {left, bar_top + bar + 3 + text_height - 4}, cv::FONT_HERSHEY_SIMPLEX, font, white,
                thickness, cv::LINE_AA);
  }
  cv::putText(canvas, name + " (" + unit + ")", {4, out.height - 6}, cv::FONT_HERSHEY_SIMPLEX, font, white, thickness,
              cv::LINE_AA);
  return out;
}

double percentile(std::vector<float> values, double q) {
  if (values.empty()) return 0.0;
  const std::size_t k = std::min(values.size() - 1, std::size_t(q * double(values.size())));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

}  // namespace

PointCloud Panorama::to_point_cloud(bool skip_flagged) const {
  PointCloud cloud;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      if (!(count.at(u, v) > 0) || !(depth.at(u, v) > 0)) continue;
      if (skip_flagged && flagged.at(u, v)) continue;
      cloud.positions.push_back(world_from_pano * (double(depth.at(u, v)) * pano.direction(u, v)));
      Rgb8 rgb;
      for (int c = 0; c < 3; ++c) rgb[c] = std::uint8_t(std::lround(std::clamp(colour.at(u, v, c), 0.f, 1.f) * 255.f));
      cloud.colours.push_back(rgb);
      cloud.variances.push_back(variance.at(u, v));
    }
  }
  return cloud;
}

void write_panorama(const fs::path& dir, const Panorama& panorama, bool overwrite) {
  AtomicDirectory out(dir, overwrite);
  const fs::path& tmp = out.temp_path();
  write_exr(tmp / "colour.exr", panorama.colour, {"R", "G", "B"});
  write_exr(tmp / "depth.exr", panorama.depth, {"Z"});
  write_exr(tmp / "variance.exr", panorama.variance, {"V"});
  write_exr(tmp / "count.exr", panorama.count, {"N"});
  ImageU8 flags(panorama.flagged.width, panorama.flagged.height, 1, 0);
  for (std::size_t i = 0; i < flags.data.size(); ++i) flags.data[i] = panorama.flagged.data[i] ? 255 : 0;
  write_png(tmp / "flags.png", flags);
  ImageU8 colour(panorama.colour.width, panorama.colour.height, 3, 0);
  for (std::size_t i = 0; i < colour.data.size(); ++i)
    colour.data[i] = std::uint8_t(std::lround(std::clamp(panorama.colour.data[i], 0.f, 1.f) * 255.f));
  write_png(tmp / "colour.png", colour);
  std::vector<float> depths, sigmas;
  for (std::size_t i = 0; i < panorama.depth.data.size(); ++i)
    if (panorama.count.data[i] > 0) {
      depths.push_back(panorama.depth.data[i]);
      sigmas.push_back(std::sqrt(panorama.variance.data[i]));
    }
  const double depth_high = std::max(0.5, percentile(depths, 0.99));
  const double sigma_high = std::max(1e-3, percentile(sigmas, 0.95));
  write_png(tmp / "depth.png", preview(panorama.depth, panorama.count, 0.0, depth_high, "radial depth", "m", 1.0));
  ImageF32 sigma(panorama.variance.width, panorama.variance.height, 1, 0.f);
  for (std::size_t i = 0; i < sigma.data.size(); ++i) sigma.data[i] = std::sqrt(panorama.variance.data[i]);
  write_png(tmp / "variance.png", preview(sigma, panorama.count, 0.0, sigma_high, "sigma_z", "mm", 1e3));
  const PointCloud cloud = panorama.to_point_cloud(false);
  PlyWriteOptions ply;
  ply.comments.push_back("panoscan panorama cloud, method " + panorama.method);
  write_ply_point_cloud(tmp / "cloud.ply", cloud, ply);

  nlohmann::json j;
  j["format"] = kPanoramaFormat;
  j["version"] = kPanoramaVersion;
  j["height"] = panorama.pano.height;
  j["width"] = panorama.pano.width();
  j["world_from_pano"] = pose_to_json(panorama.world_from_pano);
  j["axis"] = {{"point",
                {panorama.world_from_pano.translation().x(), panorama.world_from_pano.translation().y(),
                 panorama.world_from_pano.translation().z()}},
               {"direction",
                {panorama.world_from_pano.linear()(0, 2), panorama.world_from_pano.linear()(1, 2),
                 panorama.world_from_pano.linear()(2, 2)}}};
  j["method"] = panorama.method;
  j["lambda"] = panorama.lambda;
  j["files"] = {{"colour", "colour.exr (R,G,B linear 0..1)"},
                {"depth", "depth.exr (Z, radial metres, 0 = none)"},
                {"variance", "variance.exr (V, m^2)"},
                {"count", "count.exr (N)"},
                {"flags", "flags.png (255 = sigma_z above limit)"},
                {"cloud", "cloud.ply (world frame)"}};
  j["legend"] = {
      {"depth_png_m", {0.0, depth_high}},
      {"variance_png_sigma_m", {0.0, sigma_high}},
      {"colours", "dark blue (low) -> cyan -> green -> yellow -> red (high); bar with labelled ticks under the image"}};
  nlohmann::json energy = nlohmann::json::array();
  for (const EnergyRecord& e : panorama.energy)
    energy.push_back({{"iteration", e.iteration},
                      {"smoothed", e.smoothed},
                      {"data", e.data},
                      {"smoothness", e.smoothness},
                      {"lambda_smoothness", e.smoothness_weighted},
                      {"data_epsilon_m", e.data_epsilon_m}});
  j["energy"] = energy;
  j["written_by"] = {{"version", project_version()}, {"source_revision", source_revision()}};
  write_file_atomic(tmp / "panorama.json", j.dump(1) + "\n");
  out.commit();
}

Panorama read_panorama(const fs::path& dir) {
  const fs::path json_path = dir / "panorama.json";
  const nlohmann::json j = read_json_file(json_path, "not a panorama folder?");
  if (!j.is_object()) throw make_error(json_path.string(), "", "expected a JSON object");
  if (!j.contains("format") || j["format"] != kPanoramaFormat)
    throw make_error(json_path.string(), "format", std::string("expected \"") + kPanoramaFormat + "\"");
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"] != kPanoramaVersion)
    throw make_error(json_path.string(), "version", "expected " + std::to_string(kPanoramaVersion));
  Panorama p;
  // The bound of panorama.height: larger values would overflow the width (2H) and the pixel count.
  if (!j.contains("height") || !j["height"].is_number_integer() || j["height"].get<std::int64_t>() < 1 ||
      j["height"].get<std::int64_t>() > 16384)
    throw make_error(json_path.string(), "height", "expected an integer in [1, 16384]");
  p.pano.height = j["height"].get<int>();
  std::string field = "method";
  try {
    p.method = j.value("method", "");
    field = "lambda";
    p.lambda = j.value("lambda", 0.0);
    field = "energy";
    for (const auto& e : j.value("energy", nlohmann::json::array())) {
      EnergyRecord r;
      if (!e.is_object() || !e.contains("iteration") || !e["iteration"].is_number_integer())
        throw make_error(json_path.string(), "energy", "expected objects with an integer \"iteration\"");
      r.iteration = int(std::clamp<std::int64_t>(e["iteration"].get<std::int64_t>(), 0, 1 << 30));
      r.smoothed = e.at("smoothed").get<double>();
      r.data = e.at("data").get<double>();
      r.smoothness = e.at("smoothness").get<double>();
      r.smoothness_weighted = e.at("lambda_smoothness").get<double>();
      r.data_epsilon_m = e.value("data_epsilon_m", 0.0);
      p.energy.push_back(r);
    }
  } catch (const nlohmann::json::exception& e) {
    throw make_error(json_path.string(), field, e.what());
  }
  if (!j.contains("world_from_pano")) throw make_error(json_path.string(), "world_from_pano", "missing field");
  p.world_from_pano = pose_from_json(j["world_from_pano"], json_path.string(), "world_from_pano");
  const int width = p.pano.width(), height = p.pano.height;
  p.colour = read_exr(dir / "colour.exr", {"R", "G", "B"}, width, height);
  p.depth = read_exr(dir / "depth.exr", {"Z"}, width, height);
  p.variance = read_exr(dir / "variance.exr", {"V"}, width, height);
  p.count = read_exr(dir / "count.exr", {"N"}, width, height);
  for (const auto* image : {&p.colour, &p.depth, &p.variance, &p.count})
    if (image->width != p.pano.width() || image->height != p.pano.height)
      throw make_error(dir.string(), "size", "an EXR does not match height " + std::to_string(p.pano.height));
  // Values every consumer relies on (registration, integration, eval): finite, and depth, variance
  // and count not negative; a pixel with depth must have a measurement count.
  auto check_values = [&](const ImageF32& image, const char* name, bool non_negative) {
    for (std::size_t i = 0; i < image.data.size(); ++i) {
      const float value = image.data[i];
      if (!std::isfinite(value) || (non_negative && value < 0.f))
        throw make_error((dir / name).string(), "pixel " + std::to_string(i / std::size_t(image.channels)),
                         "value " + std::to_string(value) + (non_negative ? ": expected finite and >= 0" : ": expected finite"));
    }
  };
  check_values(p.colour, "colour.exr", false);
  check_values(p.depth, "depth.exr", true);
  check_values(p.variance, "variance.exr", true);
  check_values(p.count, "count.exr", true);
  for (std::size_t i = 0; i < p.depth.data.size(); ++i)
    if (p.depth.data[i] > 0.f && !(p.count.data[i] > 0.f))
      throw make_error((dir / "count.exr").string(), "pixel " + std::to_string(i),
                       "a pixel with depth has no measurement count");
  // The flags as written (flags.png, 255 = flagged); left clear if the PNG has another size.
  p.flagged = ImageU8(p.pano.width(), p.pano.height, 1, 0);
  const ImageU8 flags = read_rgb(dir / "flags.png");
  if (flags.width == p.pano.width() && flags.height == p.pano.height)
    for (int v = 0; v < p.pano.height; ++v)
      for (int u = 0; u < p.pano.width(); ++u) p.flagged.at(u, v) = flags.at(u, v, 0) > 127 ? 1 : 0;
  return p;
}

}  // namespace panoscan
