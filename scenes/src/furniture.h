// Internal to panoscan_scenes: furniture and fixtures shared by the built-in scenes.
//
// Furniture is modelled in the builder's current frame with its origin at the centre of its
// footprint on the floor, its front facing -y and x to the right seen from the front; the caller
// pushes the placement. Fixtures on walls (pictures, windows, doors, skirting) are modelled in a
// wall frame: x along the wall to the right of a viewer in the room facing it, y into the wall
// (the room is at y < 0) and z up, origin at the wall's start on the floor (see wall_frame()).
// Furniture placed in a wall frame at y = -depth/2 therefore stands with its back to that wall.
#pragma once

#include "materials.h"
#include "panoscan/core/random.h"
#include "scene_builder.h"

namespace panoscan::scenes {

// A wall of a rectangular room: `end` lies to the right of a viewer inside the room facing it.
struct Wall {
  Vec2 start, end;
  float length() const { return (end - start).norm(); }
};
Pose3 wall_frame(const Wall& wall);

// --- Fixtures in a wall frame ---
struct WindowStyle {
  float recess_depth = 0.22f;
  bool curtains = true;
  int outdoor_variant = 0;
};
void add_window(SceneBuilder& b, MaterialLibrary& m, const WallOpening& opening, const WindowStyle& style);
void add_door(SceneBuilder& b, MaterialLibrary& m, const WallOpening& opening);
void add_skirting(SceneBuilder& b, MaterialLibrary& m, float s0, float s1);
// A framed picture centred at (s, t) on the wall.
void add_picture(SceneBuilder& b, int picture_material, int frame_material, float s, float t, float width,
                 float height);
void add_whiteboard(SceneBuilder& b, MaterialLibrary& m, float s, float t, float width, float height);

// --- Furniture (footprint-centred, front towards -y) ---
void add_sofa(SceneBuilder& b, MaterialLibrary& m, float length, int frame_fabric, int cushion_fabric);
void add_armchair(SceneBuilder& b, MaterialLibrary& m, int fabric);
void add_round_table(SceneBuilder& b, MaterialLibrary& m, float radius, float height, int top_material);
void add_table(SceneBuilder& b, MaterialLibrary& m, float width, float depth, float height, int top_material,
               int leg_material, bool round_legs);
void add_dining_chair(SceneBuilder& b, MaterialLibrary& m, int seat_fabric);
void add_office_chair(SceneBuilder& b, MaterialLibrary& m);
void add_bookshelf(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, float width, float height, int shelves,
                   int wood);
void add_chest_of_drawers(SceneBuilder& b, MaterialLibrary& m, float width, float depth, float height, int drawers,
                          int body_material);
void add_floor_lamp(SceneBuilder& b, MaterialLibrary& m);
void add_table_lamp(SceneBuilder& b, MaterialLibrary& m);
// A potted plant `size` times the standard one (pot 0.3 m high); no leaf reaches further than
// max_reach from the pot's axis.
void add_plant(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, float size, float max_reach);
void add_monitor(SceneBuilder& b, MaterialLibrary& m, int screen_variant);
void add_keyboard_and_mouse(SceneBuilder& b, MaterialLibrary& m);
// A desk (1.4 x 0.7 m, 0.74 m high, laminate on dark metal) with a monitor (`screen_variant`)
// and a keyboard and mouse: the workstation of the built-in office and of generated offices.
// Origin at the centre of the desk's footprint; what else stands on it is the caller's.
void add_desk_with_screen(SceneBuilder& b, MaterialLibrary& m, int screen_variant);
// An oak chest of four drawers (0.8 x 0.45 x 0.85 m) with `books` books and a terracotta vase on
// top: the living room's dresser, built-in and generated.
void add_dresser(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, int books);
void add_tv_unit(SceneBuilder& b, MaterialLibrary& m);
void add_rug(SceneBuilder& b, MaterialLibrary& m, float width, float depth);
void add_radiator(SceneBuilder& b, MaterialLibrary& m, float width);
void add_bin(SceneBuilder& b, MaterialLibrary& m);
void add_vase(SceneBuilder& b, int material, float height, float radius);
void add_book_stack(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, int count);
void add_coat_stand(SceneBuilder& b, MaterialLibrary& m);
void add_pouf(SceneBuilder& b, int fabric);
void add_printer(SceneBuilder& b, MaterialLibrary& m);
// Ceiling fixtures at (x, y) under a ceiling at `ceiling_height` (in the scene frame).
void add_pendant_lamp(SceneBuilder& b, MaterialLibrary& m, float x, float y, float ceiling_height);
void add_ceiling_panel_light(SceneBuilder& b, MaterialLibrary& m, float x, float y, float ceiling_height);

}  // namespace panoscan::scenes
