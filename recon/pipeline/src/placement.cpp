#include "panoscan/recon/placement.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/pose_json.h"

namespace panoscan {

std::vector<int> unlinked_panoramas(int count, const std::vector<PoseGraphEdge>& edges) {
  std::vector<char> linked(std::size_t(std::max(count, 0)), 0);
  if (count > 0) linked[0] = 1;
  for (bool grew = true; grew;) {
    grew = false;
    for (const PoseGraphEdge& e : edges)
      if (linked[std::size_t(e.from)] != linked[std::size_t(e.to)]) {
        linked[std::size_t(e.from)] = linked[std::size_t(e.to)] = 1;
        grew = true;
      }
  }
  std::vector<int> unlinked;
  for (int k = 0; k < count; ++k)
    if (!linked[std::size_t(k)]) unlinked.push_back(k);
  return unlinked;
}

Placement place_panoramas(const std::vector<std::string>& names, const Rigid3d& world_from_first,
                          const std::vector<PoseGraphEdge>& edges, const PlacementOptions& options) {
  const int n = int(names.size());
  if (n == 0) throw make_error("", "placement", "no panoramas");
  for (const PoseGraphEdge& e : edges)
    if (e.from < 0 || e.from >= n || e.to < 0 || e.to >= n || e.from == e.to)
      throw make_error("", "placement",
                       fmt::format("registration {} -> {} does not link two of the {} panoramas", e.from, e.to, n));
  if (const std::vector<int> unlinked = unlinked_panoramas(n, edges); !unlinked.empty())
    throw make_error(names[std::size_t(unlinked.front())], "registrations",
                     "no chain of registrations links it to " + names[0]);
  Placement result;
  result.edge_kept.assign(edges.size(), 1);
  result.edge_in_chain.assign(edges.size(), 0);

  // 1. The chain: edges by the distance of their panoramas in the given order (stable), then
  // breadth first from panorama 0.
  std::vector<std::size_t> order(edges.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(edges[a].from - edges[a].to) < std::abs(edges[b].from - edges[b].to);
  });
  std::vector<Rigid3d>& chained = result.world_from_panorama_chained;
  chained.assign(n, Rigid3d::Identity());
  chained[0] = world_from_first;
  std::vector<char> placed(n, 0);
  placed[0] = 1;
  for (bool grew = true; grew;) {
    grew = false;
    for (std::size_t k : order) {
      const PoseGraphEdge& e = edges[k];
      if (placed[e.to] && !placed[e.from]) {
        chained[e.from] = chained[e.to] * e.to_from_from;
      } else if (placed[e.from] && !placed[e.to]) {
        chained[e.to] = chained[e.from] * e.to_from_from.inverse();
      } else {
        continue;
      }
      placed[e.from] = placed[e.to] = 1;
      result.edge_in_chain[k] = 1;
      grew = true;
    }
  }
  // Every panorama is placed: unlinked_panoramas found none above, and the chain follows the same links.

  // 2. Registrations outside the chain that contradict it.
  std::vector<PoseGraphEdge> kept;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const PoseGraphEdge& e = edges[k];
    if (!result.edge_in_chain[k]) {
      const EdgeDiscrepancy d = worst_edge_discrepancy(chained, {e});
      if (d.rotation_deg > options.max_loop_rotation_deg || d.translation_m > options.max_loop_translation_m) {
        result.edge_kept[k] = 0;
        result.dropped.push_back(fmt::format("{} -> {}: contradicts the chained registrations by {:.2f} deg, {:.0f} mm",
                                             names[e.from], names[e.to], d.rotation_deg, d.translation_m * 1e3));
        log_warn(fmt::format("registration dropped: {}", result.dropped.back()));
        continue;
      }
    }
    kept.push_back(e);
  }

  // 3. The pose graph over redundant registrations.
  result.inconsistency_chained = worst_edge_discrepancy(chained, kept);
  result.world_from_panorama = chained;
  if (int(kept.size()) > n - 1) {
    PoseGraphOptions graph = options.pose_graph;
    graph.fixed_node = 0;
    result.world_from_panorama = optimize_pose_graph(chained, kept, graph).world_from_node;
    result.pose_graph_used = true;
  }
  result.inconsistency_final = worst_edge_discrepancy(result.world_from_panorama, kept);
  return result;
}

nlohmann::json placement_to_json(const std::vector<std::string>& names, const std::vector<PoseGraphEdge>& edges,
                                 const Placement& placement) {
  nlohmann::json j;
  j["format"] = "panoscan-placement";
  j["version"] = 1;
  j["panoramas"] = nlohmann::json::array();
  for (std::size_t k = 0; k < names.size(); ++k)
    j["panoramas"].push_back(
        {{"name", names[k]}, {"world_from_panorama", pose_to_json(placement.world_from_panorama[k])}});
  j["registrations"] = nlohmann::json::array();
  for (std::size_t k = 0; k < edges.size(); ++k)
    j["registrations"].push_back({{"source", names[edges[k].from]},
                                  {"target", names[edges[k].to]},
                                  {"kept", bool(placement.edge_kept[k])},
                                  {"in_chain", bool(placement.edge_in_chain[k])}});
  j["dropped"] = placement.dropped;
  j["pose_graph_used"] = placement.pose_graph_used;
  auto discrepancy = [](const EdgeDiscrepancy& d) {
    return nlohmann::json{{"rotation_deg", d.rotation_deg}, {"translation_m", d.translation_m}};
  };
  j["inconsistency"] = {{"chained", discrepancy(placement.inconsistency_chained)},
                        {"final", discrepancy(placement.inconsistency_final)}};
  return j;
}

}  // namespace panoscan
