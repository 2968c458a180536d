// read_cloud_file: the PLY or PCD reader by extension, then the uncertainty fields as covariances.
#include "panoscan/core/cloud_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "cloud_columns.h"
#include "panoscan/core/error.h"

namespace panoscan {

namespace {

// The names read_cloud_file looks for, in this order (cloud_file.h).
const std::vector<std::string> kUncertaintyFields = {"cov_xx", "cov_xy", "cov_xz", "cov_yy",
                                                     "cov_yz", "cov_zz", "variance", "sigma"};

std::string lower_extension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// Covariances from the columns (one per kept point when present); `point_name(i)` names point i in errors.
template <class Name>
void fill_uncertainty(CloudFile& out, const std::vector<std::vector<double>>& columns, Name&& point_name) {
  const std::size_t n = out.points.size();
  // With zero points every column is empty; nothing to fill either way.
  if (n == 0) return;
  int present_cov = 0;
  for (int k = 0; k < 6; ++k)
    if (!columns[k].empty()) ++present_cov;
  if (present_cov > 0 && present_cov < 6) {
    for (int k = 0; k < 6; ++k)
      if (columns[k].empty())
        throw make_error(out.path, "field " + kUncertaintyFields[k],
                         "missing (cov_xx cov_xy cov_xz cov_yy cov_yz cov_zz go together)");
  }
  out.covariances.resize(n);
  if (present_cov == 6) {
    out.uncertainty = "cov_xx..cov_zz";
    for (std::size_t i = 0; i < n; ++i) {
      const double xx = columns[0][i], xy = columns[1][i], xz = columns[2][i], yy = columns[3][i],
                   yz = columns[4][i], zz = columns[5][i];
      Eigen::Matrix3d c;
      c << xx, xy, xz, xy, yy, yz, xz, yz, zz;
      if (!c.allFinite()) throw make_error(out.path, point_name(i), "covariance (cov_xx..cov_zz) is not finite");
      const double scale = std::max({std::abs(xx), std::abs(yy), std::abs(zz), 1e-30});
      const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c, Eigen::EigenvaluesOnly).eigenvalues()[0];
      if (smallest < -1e-9 * scale)
        throw make_error(out.path, point_name(i),
                         "covariance (cov_xx..cov_zz) is not positive semi-definite (smallest eigenvalue " +
                             std::to_string(smallest) + ")");
      out.covariances[i] = c;
    }
  } else if (!columns[6].empty() || !columns[7].empty()) {
    const bool variance = !columns[6].empty();
    const std::vector<double>& column = variance ? columns[6] : columns[7];
    out.uncertainty = variance ? "variance" : "sigma";
    for (std::size_t i = 0; i < n; ++i) {
      const double value = column[i];
      if (!std::isfinite(value) || value < 0)
        throw make_error(out.path, point_name(i), out.uncertainty + " must be finite and >= 0");
      out.covariances[i] = Eigen::Matrix3d::Identity() * (variance ? value : value * value);
    }
  } else {
    out.covariances.clear();
  }
}

}  // namespace

bool is_cloud_file_path(const std::filesystem::path& path) {
  const std::string extension = lower_extension(path);
  return extension == ".ply" || extension == ".pcd";
}

CloudFile read_cloud_file(const std::filesystem::path& path) {
  CloudFile out;
  out.path = path.string();
  const std::string extension = lower_extension(path);
  if (extension == ".ply") {
    detail::PlyVertexRequest request;
    request.attributes = false;
    request.drop_nan_points = true;
    request.extra = kUncertaintyFields;
    detail::PlyVertexExtras extras;
    PointCloud cloud = detail::read_ply_vertices(path, request, &extras);
    out.points = std::move(cloud.positions);
    out.format = extras.format;
    out.declared_points = extras.declared_points;
    out.dropped_invalid = extras.dropped_invalid;
    fill_uncertainty(out, extras.columns, [&](std::size_t i) { return "vertex " + std::to_string(extras.kept[i]); });
  } else if (extension == ".pcd") {
    detail::PcdData data = detail::read_pcd(path, kUncertaintyFields);
    out.points = std::move(data.points);
    out.format = data.format;
    out.declared_points = data.declared_points;
    out.dropped_invalid = data.dropped_invalid;
    out.has_viewpoint = data.has_viewpoint;
    out.viewpoint = data.viewpoint_translation;
    fill_uncertainty(out, data.columns, [&](std::size_t i) {
      const std::uint64_t index = data.kept[i];
      return "point " + std::to_string(index) +
             (data.first_data_line > 0 ? " (line " + std::to_string(data.first_data_line + index) + ")" : "");
    });
  } else {
    throw make_error(out.path, "extension",
                     "not a point-cloud file (expected .ply or .pcd, or a panorama folder)");
  }
  return out;
}

}  // namespace panoscan
