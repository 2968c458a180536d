// Scene lists and scan labels of the table drivers; see scene_catalog.h.
#include "scene_catalog.h"

#include <cctype>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <regex>

#include <fmt/format.h>

#include "panoscan/core/error.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/scene_loader.h"

namespace fs = std::filesystem;

namespace panoscan::tables {

namespace {

// One entry of TablesOptions::scenes, resolved.
struct SceneEntry {
  enum class Kind { kBuiltin, kGenerated, kFile } kind = Kind::kBuiltin;
  int generated_rooms = 0;  // generated:N
  fs::path file;            // a scene file
  std::string stem;         // its label prefix
};

SceneEntry parse_entry(const std::string& entry) {
  SceneEntry e;
  if (entry == "builtin") return e;
  static const std::regex generated(R"(generated:(\d{1,2}))");
  std::smatch m;
  if (std::regex_match(entry, m, generated)) {
    e.kind = SceneEntry::Kind::kGenerated;
    e.generated_rooms = std::stoi(m[1]);
    if (e.generated_rooms < 1) throw make_error("--scenes", entry, "generated:N needs N in 1..99");
    return e;
  }
  if (entry.rfind("generated", 0) == 0) throw make_error("--scenes", entry, "expected generated:N with N in 1..99");
  e.kind = SceneEntry::Kind::kFile;
  e.file = entry;
  e.stem = e.file.stem().string();
  if (!fs::is_regular_file(e.file))
    throw make_error("--scenes", entry, "is neither builtin, generated:N nor an existing scene file");
  static const std::regex reserved(R"(S[OL]|G[OL]\d+)");
  if (std::regex_match(e.stem, reserved) || e.stem.find('-') != std::string::npos || e.stem.empty())
    throw make_error("--scenes", entry,
                     "a scene file's stem is its scans' label prefix: it must not contain '-' nor be SO, SL, GO<n> "
                     "or GL<n> (rename the file)");
  return e;
}

// 64-bit FNV-1a of a file's bytes: scans of an edited scene file must not come from the cache.
std::uint64_t file_hash(const fs::path& path, std::uint64_t hash = 1469598103934665603ull) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw make_error(path.string(), "", "cannot be read");
  char buffer[1 << 16];
  while (in) {
    in.read(buffer, sizeof buffer);
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      hash ^= static_cast<unsigned char>(buffer[i]);
      hash *= 1099511628211ull;
    }
  }
  return hash;
}

std::mutex scenes_mutex;
std::map<std::string, std::shared_ptr<const Scene>> scenes_built;  // key -> scene

std::shared_ptr<const Scene> remember(const std::string& key, const std::function<Scene()>& build) {
  std::lock_guard<std::mutex> guard(scenes_mutex);
  auto it = scenes_built.find(key);
  if (it == scenes_built.end()) it = scenes_built.emplace(key, std::make_shared<const Scene>(build())).first;
  return it->second;
}

int position_index(const Scene& scene, const std::string& name, const std::string& label) {
  for (std::size_t i = 0; i < scene.positions.size(); ++i)
    if (scene.positions[i].name == name) return int(i);
  throw make_error("scan", label, fmt::format("{} has no position {} ({} positions)", scene.name, name,
                                              scene.positions.size()));
}

}  // namespace

void check_scene_list(const TablesOptions& options) {
  if (options.scenes.empty()) throw make_error("--scenes", "", "names no scene (e.g. builtin, generated:8)");
  std::map<std::string, std::string> prefixes;
  for (const std::string& entry : options.scenes) {
    const SceneEntry e = parse_entry(entry);
    const std::string prefix = e.kind == SceneEntry::Kind::kBuiltin     ? "builtin"
                               : e.kind == SceneEntry::Kind::kGenerated ? "generated"
                                                                        : e.stem;
    if (!prefixes.emplace(prefix, entry).second)
      throw make_error("--scenes", entry, "gives the same scans as " + prefixes[prefix]);
  }
}

namespace {

// The digits after a label's last dash: one for a scan ("SO-1"), two for a pair ("SO-13").
std::size_t position_digits(const std::string& label) {
  const auto dash = label.rfind('-');
  if (dash == std::string::npos) return 0;
  for (std::size_t i = dash + 1; i < label.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(label[i]))) return 0;
  return label.size() - dash - 1;
}

std::vector<std::string> only_labels(const TablesOptions& options, std::size_t digits) {
  std::vector<std::string> labels;
  for (const std::string& label : options.only)
    if (position_digits(label) == digits) labels.push_back(label);
  return labels;
}

}  // namespace

std::vector<std::string> scan_labels(const TablesOptions& options) {
  if (!options.only.empty()) return only_labels(options, 1);
  std::vector<std::string> labels;
  for (const std::string& entry : options.scenes) {
    const SceneEntry e = parse_entry(entry);
    if (e.kind == SceneEntry::Kind::kBuiltin) {
      for (const std::string& l : size_preset(options.size).scans) labels.push_back(l);
    } else if (e.kind == SceneEntry::Kind::kGenerated) {
      for (int seed = 1; seed <= e.generated_rooms; ++seed)
        labels.push_back(fmt::format("G{}{}-1", seed % 2 == 1 ? 'O' : 'L', seed));
    } else {
      labels.push_back(e.stem + "-1");
    }
  }
  return labels;
}

std::vector<std::string> pair_labels(const TablesOptions& options) {
  if (!options.only.empty()) return only_labels(options, 2);
  std::vector<std::string> labels;
  for (const std::string& entry : options.scenes) {
    const SceneEntry e = parse_entry(entry);
    if (e.kind == SceneEntry::Kind::kBuiltin) {
      for (const std::string& l : size_preset(options.size).pairs) labels.push_back(l);
    } else if (e.kind == SceneEntry::Kind::kGenerated) {
      // Generated positions 1 and 2 are neighbours sharing at least 60% of their view.
      for (int seed = 1; seed <= e.generated_rooms; ++seed)
        labels.push_back(fmt::format("G{}{}-12", seed % 2 == 1 ? 'O' : 'L', seed));
    } else {
      labels.push_back(e.stem + "-12");
    }
  }
  return labels;
}

std::vector<Column> scan_columns(const TablesOptions& options) {
  std::vector<Column> columns;
  for (const std::string& label : scan_labels(options)) columns.push_back({label, {label}});
  return columns;
}

std::vector<Column> pair_columns(const TablesOptions& options) {
  std::vector<Column> columns;
  for (const std::string& label : pair_labels(options)) {
    const auto [source, target] = pair_scans(label);
    columns.push_back({label, {source, target}});
  }
  return columns;
}

LabelledScene scene_for_label(const std::string& label, const TablesOptions& options) {
  const auto dash = label.rfind('-');
  if (dash == std::string::npos || dash == 0 || dash + 1 >= label.size())
    throw make_error("scan", label, "expected a scan label like SO-1, GO7-2 or <file stem>-1");
  const std::string prefix = label.substr(0, dash);
  const std::string position = label.substr(dash + 1);
  scenes::SceneStyle style;
  style.texture = scenes::texture_density_from_string(options.texture, "scene.texture");
  const std::string texture = options.texture;
  LabelledScene s;
  if (prefix == "SO" || prefix == "SL") {
    const std::string name = prefix == "SO" ? "office" : "living_room";
    s.key = "builtin-" + name;
    s.scene = remember(s.key + "-" + texture, [&] { return scenes::make_builtin_scene(name, style); });
    s.position = position_index(*s.scene, label, label);
    return s;
  }
  static const std::regex generated(R"(G([OL])(\d+))");
  std::smatch m;
  if (std::regex_match(prefix, m, generated)) {
    scenes::RoomSpec spec;
    spec.kind = m[1] == "O" ? scenes::RoomKind::kOffice : scenes::RoomKind::kLivingRoom;
    spec.seed = std::stoull(m[2]);
    spec.style = style;
    s.key = "generated-" + scenes::generated_room_name(spec);
    s.scene = remember(s.key + "-" + texture, [&] { return scenes::generate_room(spec).scene; });
    s.position = position_index(*s.scene, fmt::format("G{}-{}", m[1].str(), position), label);
    return s;
  }
  for (const std::string& entry : options.scenes) {
    const SceneEntry e = parse_entry(entry);
    if (e.kind != SceneEntry::Kind::kFile || e.stem != prefix) continue;
    // The mesh and the positions file load_scene_file reads (textures and MTL are not hashed).
    std::uint64_t hash = file_hash(e.file);
    const fs::path folder = e.file.parent_path();
    for (const fs::path& positions : {folder / (e.stem + ".positions.json"), folder / "positions.json"})
      if (fs::exists(positions)) hash = file_hash(positions, hash);
    s.key = fmt::format("file-{}-{:016x}", e.stem, hash);
    s.scene = remember(s.key, [&] { return load_scene_file(e.file); });
    int k = 0;
    try {
      k = std::stoi(position);
    } catch (const std::exception&) {
      k = 0;
    }
    if (k < 1 || k > int(s.scene->positions.size()))
      throw make_error("scan", label,
                       fmt::format("{} has {} positions (labels {}-1 ...)", e.file.string(), s.scene->positions.size(),
                                   e.stem));
    s.position = k - 1;
    return s;
  }
  throw make_error("scan", label,
                   "unknown scan label: not SO-n, SL-n, GOseed-n, GLseed-n, nor a file listed in --scenes");
}

}  // namespace panoscan::tables
