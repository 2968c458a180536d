// Internal to panoscan_scenes: the materials of the built-in scenes, created on first use so that a
// scene carries only the textures it shows.
#pragma once

#include <cstdint>
#include <map>
#include <utility>

#include "panoscan/scenes/scenes.h"
#include "scene_builder.h"

namespace panoscan::scenes {

// Contrast left to floor textures at the icl density: texel = mean + kFloorContrastIcl * (texel - mean).
constexpr float kFloorContrastIcl = 0.15f;

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

// The room-shell kinds: walls, floors, ceilings and the painted fixtures (trim, window reveals).
bool is_room_shell(MaterialKind kind);
bool is_floor(MaterialKind kind);

// How each kind is dressed per texture density (see scenes.h):
//   rich   the procedural texture of the kind (the look before icl).
//   icl    walls, ceilings, trim and reveals: a uniform paint albedo, no texture; floors: the kind's
//          texture with its contrast cut to kFloorContrastIcl about its mean colour; everything
//          else as rich.
//   plain  walls, ceilings, trim and reveals as icl; everything else the mean colour of its
//          texture, no texture.
class MaterialLibrary {
 public:
  MaterialLibrary(SceneBuilder& builder, std::uint64_t scene_seed, TextureDensity density = TextureDensity::kRich)
      : builder_(builder), scene_seed_(scene_seed), density_(density) {}

  // The material index of `kind` (variant picks one of several pictures), created on first use.
  int operator()(MaterialKind kind, int variant = 0);

  TextureDensity density() const { return density_; }

 private:
  SceneBuilder& builder_;
  std::uint64_t scene_seed_;
  TextureDensity density_;
  std::map<std::pair<MaterialKind, int>, int> created_;
};

}  // namespace panoscan::scenes
