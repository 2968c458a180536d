#include "materials.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "panoscan/core/random.h"
#include "procedural_textures.h"

namespace panoscan::scenes {

namespace {

struct MaterialRecipe {
  std::string name;
  Texture texture;
  float tile_size_m = 1.f;  // metres per texture repeat (fitted quads ignore it)
};

// Texel sizes: room shells ~2-2.4 mm (1024 px over 2-2.4 m), furniture ~1-2 mm, small parts finer.
MaterialRecipe recipe(MaterialKind kind, int variant, std::uint64_t seed) {
  const std::string v = variant ? "_" + std::to_string(variant) : "";
  switch (kind) {
    case MaterialKind::kDamaskWallpaper:
      return {"damask_wallpaper", damask_wallpaper_texture("damask_wallpaper", 1024, seed), 2.4f};
    case MaterialKind::kStripedWallpaper:
      return {"striped_wallpaper", striped_wallpaper_texture("striped_wallpaper", 1024, seed), 2.4f};
    case MaterialKind::kGeometricWallpaper:
      return {"geometric_wallpaper", geometric_wallpaper_texture("geometric_wallpaper", 1024, seed), 2.4f};
    case MaterialKind::kBrickWall: return {"brick_wall", brick_texture("brick_wall", 1024, seed), 2.0f};
    case MaterialKind::kParquetFloor: return {"parquet_floor", parquet_texture("parquet_floor", 1024, seed), 2.0f};
    case MaterialKind::kCarpetTiles: return {"carpet_tiles", carpet_tiles_texture("carpet_tiles", 1024, seed), 2.0f};
    case MaterialKind::kCofferedCeiling:
      return {"coffered_ceiling", coffered_ceiling_texture("coffered_ceiling", 1024, seed), 2.4f};
    case MaterialKind::kAcousticCeiling:
      return {"acoustic_ceiling", acoustic_ceiling_texture("acoustic_ceiling", 1024, seed), 2.4f};
    case MaterialKind::kTrimPaint:
      return {"trim_paint", plaster_texture("trim_paint", 512, seed, Colour(0.93f, 0.92f, 0.88f)), 1.0f};
    case MaterialKind::kPlaster:
      return {"plaster", plaster_texture("plaster", 512, seed, Colour(0.85f, 0.80f, 0.68f)), 1.0f};
    case MaterialKind::kOutdoorView:
      return {"outdoor_view" + v, outdoor_view_texture("outdoor_view" + v, 512, seed), 1.0f};
    case MaterialKind::kDoorLeaf: return {"door_leaf", door_texture("door_leaf", 512, seed), 1.0f};
    case MaterialKind::kOakWood:
      return {"oak_wood", wood_texture("oak_wood", 512, seed, Colour(0.82f, 0.64f, 0.42f), Colour(0.50f, 0.33f, 0.18f)),
              0.8f};
    case MaterialKind::kWalnutWood:
      return {"walnut_wood",
              wood_texture("walnut_wood", 512, seed, Colour(0.62f, 0.42f, 0.26f), Colour(0.24f, 0.14f, 0.07f)), 0.8f};
    case MaterialKind::kDeskLaminate:
      return {"desk_laminate",
              wood_texture("desk_laminate", 512, seed, Colour(0.88f, 0.80f, 0.66f), Colour(0.62f, 0.50f, 0.36f)), 1.0f};
    case MaterialKind::kPlaidFabric: return {"plaid_fabric", plaid_fabric_texture("plaid_fabric", 512, seed), 0.5f};
    case MaterialKind::kUpholsteryBlue:
      return {
          "upholstery_blue",
          upholstery_texture("upholstery_blue", 512, seed, Colour(0.15f, 0.22f, 0.42f), Colour(0.85f, 0.80f, 0.60f)),
          0.5f};
    case MaterialKind::kUpholsteryOchre:
      return {"upholstery_ochre",
              upholstery_texture("upholstery_ochre", 512, seed, Colour(0.75f, 0.55f, 0.2f), Colour(0.2f, 0.12f, 0.08f)),
              0.5f};
    case MaterialKind::kBrushedSteel:
      return {"brushed_steel", brushed_metal_texture("brushed_steel", 256, seed, Colour(0.72f, 0.73f, 0.75f)), 0.3f};
    case MaterialKind::kDarkMetal:
      return {"dark_metal", brushed_metal_texture("dark_metal", 256, seed, Colour(0.25f, 0.25f, 0.27f)), 0.3f};
    case MaterialKind::kDarkPlastic: return {"dark_plastic", dark_plastic_texture("dark_plastic", 256, seed), 0.25f};
    case MaterialKind::kBookSpines: return {"book_spines", book_spines_texture("book_spines", 512, seed), 0.5f};
    case MaterialKind::kPaperEdges: return {"paper_edges", paper_edges_texture("paper_edges", 256, seed), 0.15f};
    case MaterialKind::kLeaf: return {"leaf", leaf_texture("leaf", 256, seed), 0.2f};
    case MaterialKind::kTerracotta: return {"terracotta", terracotta_texture("terracotta", 256, seed), 0.35f};
    case MaterialKind::kSoil: return {"soil", soil_texture("soil", 256, seed), 0.3f};
    case MaterialKind::kLampshade: return {"lampshade", lampshade_texture("lampshade", 256, seed), 0.3f};
    case MaterialKind::kCeramicTiles: return {"ceramic_tiles", ceramic_tiles_texture("ceramic_tiles", 512, seed), 0.6f};
    case MaterialKind::kMeshFabric: return {"mesh_fabric", mesh_fabric_texture("mesh_fabric", 256, seed), 0.3f};
    case MaterialKind::kRug: return {"rug", rug_texture("rug", 1024, seed), 1.0f};
    case MaterialKind::kScreen: return {"screen" + v, screen_texture("screen" + v, 512, seed), 1.0f};
    case MaterialKind::kTvPicture: return {"tv_picture", tv_picture_texture("tv_picture", 512, seed), 1.0f};
    case MaterialKind::kKeyboard: return {"keyboard", keyboard_texture("keyboard", 512, seed), 1.0f};
    case MaterialKind::kWhiteboard: return {"whiteboard", whiteboard_texture("whiteboard", 512, seed), 1.0f};
    case MaterialKind::kPoster: return {"poster" + v, poster_texture("poster" + v, 512, seed), 1.0f};
  }
  return {"unknown", Texture{}, 1.f};
}

// Plain paint of a room-shell kind at the icl and plain densities: plausible emulsion colours, a
// different one per wall kind, all below 0.87 so that the brightest lit spot (shading up to 1.13)
// does not clip.
struct Paint {
  const char* name;
  Eigen::Vector3f albedo;
};
Paint paint(MaterialKind kind) {
  switch (kind) {
    case MaterialKind::kDamaskWallpaper: return {"wall_paint_cream", {0.82f, 0.77f, 0.66f}};
    case MaterialKind::kStripedWallpaper: return {"wall_paint_sage", {0.68f, 0.74f, 0.64f}};
    case MaterialKind::kGeometricWallpaper: return {"wall_paint_blue_grey", {0.66f, 0.72f, 0.78f}};
    case MaterialKind::kBrickWall: return {"wall_paint_light_grey", {0.80f, 0.80f, 0.77f}};
    case MaterialKind::kCofferedCeiling: return {"ceiling_paint", {0.86f, 0.85f, 0.82f}};
    case MaterialKind::kAcousticCeiling: return {"ceiling_paint_office", {0.84f, 0.84f, 0.83f}};
    case MaterialKind::kTrimPaint: return {"trim_paint", {0.86f, 0.85f, 0.81f}};
    case MaterialKind::kPlaster: return {"plaster", {0.80f, 0.76f, 0.65f}};
    default: return {"paint", {0.8f, 0.8f, 0.8f}};
  }
}

Eigen::Vector3d mean_colour(const Texture& texture) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const std::size_t texels = static_cast<std::size_t>(texture.width) * texture.height;
  for (std::size_t i = 0; i < texels; ++i)
    for (int c = 0; c < 3; ++c) sum[c] += texture.rgb[3 * i + c];
  return sum / (255.0 * static_cast<double>(std::max<std::size_t>(1, texels)));
}

// The texture with its contrast about its mean colour scaled by `contrast`.
void reduce_contrast(Texture& texture, float contrast) {
  const Eigen::Vector3d mean = 255.0 * mean_colour(texture);
  for (std::size_t i = 0; i < texture.rgb.size(); ++i) {
    const double m = mean[static_cast<int>(i % 3)];
    const double value = m + contrast * (texture.rgb[i] - m);
    texture.rgb[i] = static_cast<std::uint8_t>(std::clamp(std::lround(value), 0l, 255l));
  }
}

}  // namespace

bool is_floor(MaterialKind kind) { return kind == MaterialKind::kParquetFloor || kind == MaterialKind::kCarpetTiles; }

bool is_room_shell(MaterialKind kind) {
  switch (kind) {
    case MaterialKind::kDamaskWallpaper:
    case MaterialKind::kStripedWallpaper:
    case MaterialKind::kGeometricWallpaper:
    case MaterialKind::kBrickWall:
    case MaterialKind::kParquetFloor:
    case MaterialKind::kCarpetTiles:
    case MaterialKind::kCofferedCeiling:
    case MaterialKind::kAcousticCeiling:
    case MaterialKind::kTrimPaint:
    case MaterialKind::kPlaster: return true;
    default: return false;
  }
}

int MaterialLibrary::operator()(MaterialKind kind, int variant) {
  const auto key = std::make_pair(kind, variant);
  auto found = created_.find(key);
  if (found != created_.end()) return found->second;
  int material = -1;
  if (density_ != TextureDensity::kRich && is_room_shell(kind) && !is_floor(kind)) {
    // Painted: no texture is generated at all.
    const Paint p = paint(kind);
    material = builder_.add_material(p.name, -1, 1.f, p.albedo);
  } else {
    // Each texture's seed depends only on the scene, the kind and the variant, not on creation order.
    const std::uint64_t seed = mix64(scene_seed_ * 1000003ull + static_cast<std::uint64_t>(kind) * 131ull +
                                     static_cast<std::uint64_t>(variant));
    MaterialRecipe made = recipe(kind, variant, seed);
    if (density_ == TextureDensity::kPlain) {
      material = builder_.add_material(made.name, -1, made.tile_size_m, mean_colour(made.texture).cast<float>());
    } else {
      if (density_ == TextureDensity::kIcl && is_floor(kind)) reduce_contrast(made.texture, kFloorContrastIcl);
      const int texture = builder_.add_texture(std::move(made.texture));
      material = builder_.add_material(made.name, texture, made.tile_size_m);
    }
  }
  created_.emplace(key, material);
  return material;
}

}  // namespace panoscan::scenes
