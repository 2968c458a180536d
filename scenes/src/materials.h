// Internal to panoscan_scenes: the materials of the built-in scenes, created on first use so that a
// scene carries only the textures it shows.
#pragma once

#include <cstdint>
#include <map>
#include <utility>

#include "scene_builder.h"

namespace panoscan::scenes {

enum class MaterialKind {
  // Room shells.
  kDamaskWallpaper,
  kStripedWallpaper,
  kGeometricWallpaper,
  kBrickWall,
  kParquetFloor,
  kCarpetTiles,
  kCofferedCeiling,
  kAcousticCeiling,
  // Fixtures.
  kTrimPaint,    // skirting boards, door and window frames
  kPlaster,      // window reveals
  kOutdoorView,  // fitted: the view out of a window
  kDoorLeaf,     // fitted
  // Furniture.
  kOakWood,
  kWalnutWood,
  kDeskLaminate,
  kPlaidFabric,
  kUpholsteryBlue,
  kUpholsteryOchre,
  kBrushedSteel,
  kDarkMetal,
  kDarkPlastic,
  kBookSpines,  // fitted per book: one spine of the atlas
  kPaperEdges,
  kLeaf,
  kTerracotta,
  kSoil,
  kLampshade,
  kCeramicTiles,
  kMeshFabric,
  kRug,         // fitted
  kScreen,      // fitted, variant = which desktop
  kTvPicture,   // fitted
  kKeyboard,    // fitted
  kWhiteboard,  // fitted
  kPoster,      // fitted, variant = which poster
};

class MaterialLibrary {
 public:
  MaterialLibrary(SceneBuilder& builder, std::uint64_t scene_seed) : builder_(builder), scene_seed_(scene_seed) {}

  // The material index of `kind` (variant picks one of several pictures), created on first use.
  int operator()(MaterialKind kind, int variant = 0);

 private:
  SceneBuilder& builder_;
  std::uint64_t scene_seed_;
  std::map<std::pair<MaterialKind, int>, int> created_;
};

}  // namespace panoscan::scenes
