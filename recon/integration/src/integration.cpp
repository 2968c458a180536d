#include "panoscan/recon/integration.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "panoscan/core/error.h"
#include "panoscan/core/kdtree.h"

namespace panoscan {

const char* to_string(MergeMethod method) {
  switch (method) {
    case MergeMethod::kAlignOnly: return "align";
    case MergeMethod::kAverage: return "average";
    case MergeMethod::kMap: return "map";
  }
  return "?";
}

MergeMethod merge_method_from_string(const std::string& name) {
  for (MergeMethod m : {MergeMethod::kAlignOnly, MergeMethod::kAverage, MergeMethod::kMap})
    if (name == to_string(m)) return m;
  throw make_error("", "integration method", "unknown '" + name + "' (align, average, map)");
}

void IntegrationOptions::check() const {
  if (!(max_correspondence_m > 0)) throw make_error("", "integration.max_correspondence_m", "must be positive");
}

namespace {

// Union-find with path halving and union by size.
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n) : parent_(n), size_(n, 1) { std::iota(parent_.begin(), parent_.end(), 0); }
  std::size_t find(std::size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size_[a] < size_[b] || (size_[a] == size_[b] && b < a)) std::swap(a, b);  // deterministic
    parent_[b] = a;
    size_[a] += size_[b];
  }

 private:
  std::vector<std::size_t> parent_, size_;
};

// Symmetric positive-definite matrix to a power (-1 or -1/2) through its eigen-decomposition.
Eigen::Matrix3d spd_power(const Eigen::Matrix3d& m, double power) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(m);
  const Eigen::Vector3d values = eigen.eigenvalues().cwiseMax(1e-12).array().pow(power);
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

}  // namespace

IntegrationResult integrate_panoramas(const std::vector<PanoramaPoints>& panoramas, const IntegrationOptions& options) {
  options.check();
  if (panoramas.empty()) throw make_error("", "integration", "no panoramas");
  const bool need_covariances = options.method == MergeMethod::kMap;
  bool all_coloured = true;
  std::vector<std::size_t> offsets{0};
  for (std::size_t k = 0; k < panoramas.size(); ++k) {
    const PanoramaPoints& p = panoramas[k];
    const std::string name = "panorama " + std::to_string(k);
    if (p.points.empty()) throw make_error("", name, "has no points");
    if (!p.covariances.empty() && p.covariances.size() != p.points.size())
      throw make_error("", name, "needs one covariance per point");
    if (need_covariances && p.covariances.empty()) throw make_error("", name, "MAP merging needs covariances");
    if (!p.colours.empty() && p.colours.size() != p.points.size())
      throw make_error("", name, "needs one colour per point");
    if (!p.world_from_panorama.matrix().allFinite()) throw make_error("", name, "non-finite pose");
    all_coloured = all_coloured && !p.colours.empty();
    offsets.push_back(offsets.back() + p.points.size());
  }
  const std::size_t total = offsets.back();

  // Every point in the scene frame, with its covariance rotated there (R_k O_k R_k^T).
  std::vector<Eigen::Vector3d> world(total);
  std::vector<Eigen::Matrix3d> world_covariance(need_covariances || !panoramas[0].covariances.empty() ? total : 0);
  for (std::size_t k = 0; k < panoramas.size(); ++k) {
    const PanoramaPoints& p = panoramas[k];
    const Eigen::Matrix3d rotation = p.world_from_panorama.linear();
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      const Eigen::Vector3d w = p.world_from_panorama * p.points[i];
      if (!w.allFinite())
        throw make_error("", "panorama " + std::to_string(k), "non-finite point " + std::to_string(i));
      world[offsets[k] + i] = w;
      if (!world_covariance.empty() && !p.covariances.empty())
        world_covariance[offsets[k] + i] = rotation * p.covariances[i] * rotation.transpose();
    }
  }

  IntegrationResult result;
  result.input_points = total;
  DisjointSets sets(total);
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  if (options.method != MergeMethod::kAlignOnly) {
    // Nearest neighbour of every point in every other panorama (scene frame).
    std::vector<std::unique_ptr<PointKdTree>> trees;
    for (std::size_t k = 0; k < panoramas.size(); ++k)
      trees.push_back(std::make_unique<PointKdTree>(
          std::vector<Eigen::Vector3d>(world.begin() + offsets[k], world.begin() + offsets[k + 1])));
    for (std::size_t a = 0; a < panoramas.size(); ++a)
      for (std::size_t b = a + 1; b < panoramas.size(); ++b) {
        const std::size_t na = offsets[a + 1] - offsets[a], nb = offsets[b + 1] - offsets[b];
        std::vector<long> a_to_b(na), b_to_a(nb);
        arena.execute([&] {
          tbb::parallel_for(std::size_t(0), na, [&](std::size_t i) {
            a_to_b[i] = trees[b]->nearest_within(world[offsets[a] + i], options.max_correspondence_m);
          });
          tbb::parallel_for(std::size_t(0), nb, [&](std::size_t j) {
            b_to_a[j] = trees[a]->nearest_within(world[offsets[b] + j], options.max_correspondence_m);
          });
        });
        // Mutual best correspondences are mergeable pairs (serial: union order is fixed).
        for (std::size_t i = 0; i < na; ++i) {
          const long j = a_to_b[i];
          if (j >= 0 && b_to_a[std::size_t(j)] == long(i)) {
            sets.unite(offsets[a] + i, offsets[b] + std::size_t(j));
            ++result.mutual_pairs;
          }
        }
      }
  }

  // Groups in order of their smallest member, so the output order is deterministic.
  std::vector<std::vector<std::size_t>> members(total);
  for (std::size_t i = 0; i < total; ++i) members[sets.find(i)].push_back(i);
  const bool with_variances = !world_covariance.empty();
  PointCloud& cloud = result.cloud;
  for (std::size_t root = 0; root < total; ++root) {
    const auto& group = members[root];
    if (group.empty()) continue;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    if (group.size() == 1) {
      position = world[group[0]];
      if (with_variances) covariance = world_covariance[group[0]];
    } else {
      ++result.groups;
      result.grouped_points += group.size();
      if (options.method == MergeMethod::kMap) {
        // Eq. 11: Y = [sum W_k]^-1 [sum W_k T_k P_k].
        const double power = options.weighting == MapWeighting::kInformation ? -1.0 : -0.5;
        Eigen::Matrix3d weight_sum = Eigen::Matrix3d::Zero(), information = Eigen::Matrix3d::Zero();
        Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
        for (std::size_t m : group) {
          const Eigen::Matrix3d w = spd_power(world_covariance[m], power);
          weight_sum += w;
          weighted += w * world[m];
          information += spd_power(world_covariance[m], -1.0);
        }
        position = weight_sum.inverse() * weighted;
        covariance = information.inverse();  // of the fused point (independent observations)
      } else {
        for (std::size_t m : group) position += world[m];
        position /= double(group.size());
        if (with_variances) {
          for (std::size_t m : group) covariance += world_covariance[m];
          covariance /= double(group.size() * group.size());  // variance of a mean
        }
      }
    }
    cloud.positions.push_back(position);
    result.observations.push_back(static_cast<std::uint32_t>(group.size()));
    if (with_variances) cloud.variances.push_back(float(covariance.trace() / 3.0));
    if (all_coloured) {
      // Colours: the mean over the group.
      Eigen::Vector3d colour = Eigen::Vector3d::Zero();
      for (std::size_t m : group) {
        const std::size_t k = std::upper_bound(offsets.begin(), offsets.end(), m) - offsets.begin() - 1;
        const Rgb8& c = panoramas[k].colours[m - offsets[k]];
        colour += Eigen::Vector3d(c[0], c[1], c[2]);
      }
      colour /= double(group.size());
      cloud.colours.push_back({std::uint8_t(std::lround(colour.x())), std::uint8_t(std::lround(colour.y())),
                               std::uint8_t(std::lround(colour.z()))});
    }
  }
  return result;
}

}  // namespace panoscan
