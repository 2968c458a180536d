// Which rooms a table run measures (TablesOptions::scenes) and what a scan label means: the
// built-in office and living room ("SO-3", "SL-1"), rooms of the seeded generator ("GO7-2": the
// office of seed 7, its position GO-2; "GL8-1": the living room of seed 8), and scene files given
// by path ("<stem>-2": the file's second position). One place decides, so that every driver, the
// scan cache and the mesh used for the errors agree.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "panoscan/core/mesh.h"
#include "panoscan/tables/tables.h"

namespace panoscan::tables {

struct LabelledScene {
  std::shared_ptr<const Scene> scene;  // at the options' texture density (files keep their own materials)
  int position = -1;                   // index into scene->positions
  // What names the scene in cache keys: "builtin-office", "generated-office-seed7",
  // "file-<stem>-<content hash>".
  std::string key;
};
// Throws Error naming the label for an unknown prefix, a position the scene does not have, or a
// scene file not listed in options.scenes. Scenes are built once per process and kept.
LabelledScene scene_for_label(const std::string& label, const TablesOptions& options);

// Checks every entry of options.scenes (known word, N in 1..99, file exists and loads) and that
// no two entries give the same prefix. Throws Error naming the entry.
void check_scene_list(const TablesOptions& options);

}  // namespace panoscan::tables
