// Internal to panoscan_scenes: procedural textures for the built-in scenes.
//
// The simulator's cameras track with ORB (FAST threshold 20), so every texture carries high-contrast
// detail with corners (joints, grout, motifs, marks) at the scale of 1-5 cm, which is what a 640x480
// camera with fx = 570 sees as a few pixels to a few tens of pixels at 1-4 m. Fine per-texel noise is
// kept weak: it would alias in the renderer and give unstable corners.
//
// All textures except the "fitted" ones (pictures stretched once over a quad: posters, screens,
// rugs, the view out of a window, keyboards, doors, whiteboards) tile seamlessly: drawing wraps
// around the edges and the noise is periodic. Every generator is deterministic in its seed.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "panoscan/core/mesh.h"

namespace panoscan::scenes {

using Colour = Eigen::Vector3f;  // sRGB-ish in [0, 1] (also declared in texture_canvas.h)

// --- Room shells (tiling, 1024 px) ---
// Basket-weave parquet: squares of four planks, alternating direction, with grain, gaps and knots.
Texture parquet_texture(const std::string& name, int size, std::uint64_t seed);
// Wallpaper with staggered flower motifs and pin stripes in strong colours on a light ground.
Texture damask_wallpaper_texture(const std::string& name, int size, std::uint64_t seed);
// Wallpaper of vertical stripes of varying widths with scattered sprigs of leaves across them.
Texture striped_wallpaper_texture(const std::string& name, int size, std::uint64_t seed);
// Wallpaper of triangles in a palette of contrasting colours.
Texture geometric_wallpaper_texture(const std::string& name, int size, std::uint64_t seed);
// Exposed brick with mortar joints, per-brick colour and chipped faces.
Texture brick_texture(const std::string& name, int size, std::uint64_t seed);
// Decorative coffered ceiling: bevelled frames, rosettes and corner blocks, with stains.
Texture coffered_ceiling_texture(const std::string& name, int size, std::uint64_t seed);
// Suspended ceiling: acoustic tiles with fissures and pinholes in a T-bar grid.
Texture acoustic_ceiling_texture(const std::string& name, int size, std::uint64_t seed);
// Carpet tiles laid quarter-turned, with stripes and coloured flecks.
Texture carpet_tiles_texture(const std::string& name, int size, std::uint64_t seed);

// --- Materials of furniture (tiling) ---
// Wood grain along u (boards with joints and knots); `light`/`dark` set the species.
Texture wood_texture(const std::string& name, int size, std::uint64_t seed, const Colour& light, const Colour& dark);
// Woven plaid: crossing bands of colour over a twill weave.
Texture plaid_fabric_texture(const std::string& name, int size, std::uint64_t seed);
// Upholstery with a staggered pattern of dots and small crosses.
Texture upholstery_texture(const std::string& name, int size, std::uint64_t seed, const Colour& ground,
                           const Colour& pattern);
// Glazed ceramic tiles with grout and simple painted motifs.
Texture ceramic_tiles_texture(const std::string& name, int size, std::uint64_t seed);
// Rows of book spines: colours, bands near top and bottom, title marks.
Texture book_spines_texture(const std::string& name, int size, std::uint64_t seed);
// Page edges of books and stacks of paper.
Texture paper_edges_texture(const std::string& name, int size, std::uint64_t seed);
// Brushed metal with scratches.
Texture brushed_metal_texture(const std::string& name, int size, std::uint64_t seed, const Colour& tint);
// Dark plastic with moulded specks (monitor and TV housings, keyboards' bodies).
Texture dark_plastic_texture(const std::string& name, int size, std::uint64_t seed);
// Painted plaster with stains, hairline cracks and pinholes (window reveals, frames).
Texture plaster_texture(const std::string& name, int size, std::uint64_t seed, const Colour& paint);
// Leaf surface: green with veins and spots.
Texture leaf_texture(const std::string& name, int size, std::uint64_t seed);
// Terracotta pot with a painted band of zigzags.
Texture terracotta_texture(const std::string& name, int size, std::uint64_t seed);
// Potting soil with pebbles.
Texture soil_texture(const std::string& name, int size, std::uint64_t seed);
// Printed lampshade linen.
Texture lampshade_texture(const std::string& name, int size, std::uint64_t seed);
// Mesh fabric of office chairs: a diamond lattice.
Texture mesh_fabric_texture(const std::string& name, int size, std::uint64_t seed);

// --- Pictures stretched once over a quad (fitted) ---
// Poster: blobs, shapes, stripes and text-like marks.
Texture poster_texture(const std::string& name, int size, std::uint64_t seed);
// Computer desktop: wallpaper, windows with title bars and text, icons.
Texture screen_texture(const std::string& name, int size, std::uint64_t seed);
// A TV picture: landscape with sky, hills, trees and a channel logo.
Texture tv_picture_texture(const std::string& name, int size, std::uint64_t seed);
// The view out of a window: sky, buildings with many windows, trees.
Texture outdoor_view_texture(const std::string& name, int size, std::uint64_t seed);
// Rug: nested borders and a field of medallions.
Texture rug_texture(const std::string& name, int size, std::uint64_t seed);
// Keyboard seen from above (for a quad about 3.4 times wider than deep).
Texture keyboard_texture(const std::string& name, int size, std::uint64_t seed);
// Panelled door with wood grain (for a quad about 0.9 m x 2.05 m).
Texture door_texture(const std::string& name, int size, std::uint64_t seed);
// Whiteboard with marker drawings and writing.
Texture whiteboard_texture(const std::string& name, int size, std::uint64_t seed);

}  // namespace panoscan::scenes
