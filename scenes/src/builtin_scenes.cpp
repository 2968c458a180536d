// The two built-in scenes. Rooms span [0, width] x [0, depth] x [0, height] in the scene frame.
//
// Layout rule: furniture stands along the walls and the scanning positions lie in the open middle,
// at least 0.6 m from anything below 1.5 m (the rig and the 0.5 m minimum depth need that), and
// close enough to each other (under 3 m) that their panoramas see mostly the same room.
#include <cmath>
#include <string>

#include "furniture.h"
#include "materials.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/random.h"
#include "panoscan/scenes/scenes.h"
#include "scene_builder.h"

namespace panoscan::scenes {

namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr std::uint64_t kLivingRoomSeed = 20201;
constexpr std::uint64_t kOfficeSeed = 20202;

using MK = MaterialKind;

// The four walls of the room [0, width] x [0, depth], each running left to right as seen from inside.
struct RoomWalls {
  Wall south, west, north, east;
};
RoomWalls room_walls(float width, float depth) {
  return {Wall{Vec2(width, 0.f), Vec2(0.f, 0.f)}, Wall{Vec2(0.f, 0.f), Vec2(0.f, depth)},
          Wall{Vec2(0.f, depth), Vec2(width, depth)}, Wall{Vec2(width, depth), Vec2(width, 0.f)}};
}

void add_floor_and_ceiling(SceneBuilder& b, float width, float depth, float height, int floor, int ceiling) {
  b.add_quad(Vec3(0.f, 0.f, 0.f), Vec3(width, 0.f, 0.f), Vec3(width, depth, 0.f), Vec3(0.f, depth, 0.f), floor);
  b.add_quad(Vec3(0.f, 0.f, height), Vec3(0.f, depth, height), Vec3(width, depth, height), Vec3(width, 0.f, height),
             ceiling);
}

// Pushes the frame of a piece of furniture standing with its back to `wall`, centred at `s` along it,
// its footprint `depth` deep; yaw turns it about its own centre (pi: facing the wall).
void push_against_wall(SceneBuilder& b, const Wall& wall, float s, float depth, float yaw = 0.f) {
  b.push(wall_frame(wall) * place(Vec3(s, -0.5f * depth - 0.01f, 0.f), yaw));
}

ScanPosition position(const std::string& name, double x, double y, double heading_rad) {
  ScanPosition p;
  p.name = name;
  p.floor_point = Eigen::Vector3d(x, y, 0.0);
  p.start_heading_rad = heading_rad;
  return p;
}

PointLight light(float x, float y, float z, float intensity) {
  PointLight l;
  l.position = Eigen::Vector3f(x, y, z);
  l.intensity = intensity;
  return l;
}

// ------------------------------------------------------------------------------------------------
// Living room (paper: SL): 5.6 m x 4.6 m, 2.7 m high. Sofa, coffee table and rug on the south side,
// TV and chest of drawers on the north wall beside the door, bookshelf and armchair on the west,
// window with curtains and radiator and a writing desk on the east.
Scene make_living_room(const SceneStyle& style) {
  const float width = 5.6f, depth = 4.6f, height = 2.7f;
  SceneBuilder b("living_room");
  MaterialLibrary m(b, kLivingRoomSeed, style.texture);
  RandomStream rng(kLivingRoomSeed, 0, 0, RandomPurpose::kScene, 1);
  const RoomWalls walls = room_walls(width, depth);
  const WallOpening door{0.45f, 1.35f, 0.f, 2.05f};    // north wall, s = x
  const WallOpening window{1.4f, 3.0f, 0.85f, 2.25f};  // east wall, s = depth - y

  add_floor_and_ceiling(b, width, depth, height, m(MK::kParquetFloor), m(MK::kCofferedCeiling));
  b.add_wall(walls.south.start, walls.south.end, height, {}, m(MK::kDamaskWallpaper));
  b.add_wall(walls.west.start, walls.west.end, height, {}, m(MK::kStripedWallpaper));
  b.add_wall(walls.north.start, walls.north.end, height, {door}, m(MK::kDamaskWallpaper));
  b.add_wall(walls.east.start, walls.east.end, height, {window}, m(MK::kStripedWallpaper));

  // South wall (s = width - x): sofa, side table with lamp, floor lamp, two posters.
  b.push(wall_frame(walls.south));
  add_skirting(b, m, 0.f, width);
  add_picture(b, m(MK::kPoster, 0), m(MK::kWalnutWood), 2.3f, 1.65f, 0.55f, 0.75f);
  add_picture(b, m(MK::kPoster, 1), m(MK::kWalnutWood), 3.3f, 1.65f, 0.55f, 0.75f);
  b.pop();
  push_against_wall(b, walls.south, 2.8f, 0.9f);
  add_sofa(b, m, 2.1f, m(MK::kUpholsteryBlue), m(MK::kPlaidFabric));
  b.pop();
  push_against_wall(b, walls.south, 4.3f, 0.45f);
  add_table(b, m, 0.45f, 0.45f, 0.55f, m(MK::kOakWood), m(MK::kOakWood), true);
  b.push(place(Vec3(0.f, 0.f, 0.55f)));
  add_table_lamp(b, m);
  b.pop();
  b.pop();
  push_against_wall(b, walls.south, 1.3f, 0.44f);
  add_floor_lamp(b, m);
  b.pop();

  // Middle: rug, round coffee table with a vase and books.
  b.push(place(Vec3(2.8f, 1.45f, 0.f)));
  add_rug(b, m, 2.6f, 1.8f);
  b.pop();
  b.push(place(Vec3(2.8f, 1.5f, 0.f)));
  add_round_table(b, m, 0.45f, 0.42f, m(MK::kOakWood));
  b.push(place(Vec3(-0.15f, 0.1f, 0.42f)));
  add_vase(b, m(MK::kCeramicTiles), 0.3f, 0.07f);
  b.pop();
  b.push(place(Vec3(0.15f, -0.1f, 0.42f), 0.4f));
  add_book_stack(b, m, rng, 3);
  b.pop();
  b.pop();

  // West wall (s = y): bookshelf, armchair, a picture; plant in the south-west corner.
  b.push(wall_frame(walls.west));
  add_skirting(b, m, 0.f, depth);
  add_picture(b, m(MK::kPoster, 2), m(MK::kDarkMetal), 3.55f, 1.7f, 0.8f, 0.55f);
  b.pop();
  push_against_wall(b, walls.west, 1.5f, 0.32f);
  add_bookshelf(b, m, rng, 1.2f, 2.0f, 5, m(MK::kWalnutWood));
  b.pop();
  b.push(place(Vec3(0.75f, 3.55f, 0.f), 0.5f * kPi));
  add_armchair(b, m, m(MK::kUpholsteryOchre));
  b.pop();
  b.push(place(Vec3(0.4f, 0.4f, 0.f)));
  add_plant(b, m, rng, 1.0f, 0.38f);
  b.pop();
  b.push(place(Vec3(0.35f, 2.78f, 0.f)));  // side table with a lamp beside the armchair
  add_round_table(b, m, 0.25f, 0.55f, m(MK::kWalnutWood));
  b.push(place(Vec3(0.f, 0.f, 0.55f)));
  add_table_lamp(b, m);
  b.pop();
  b.pop();
  b.push(place(Vec3(1.0f, 1.25f, 0.f)));
  add_pouf(b, m(MK::kPlaidFabric));
  b.pop();

  // North wall (s = x): door, chest of drawers with a picture above, TV unit; plant in the corner.
  b.push(wall_frame(walls.north));
  add_door(b, m, door);
  add_skirting(b, m, 0.f, door.s0 - 0.08f);
  add_skirting(b, m, door.s1 + 0.08f, width);
  add_picture(b, m(MK::kPoster, 3), m(MK::kOakWood), 1.95f, 1.6f, 0.45f, 0.6f);
  b.pop();
  push_against_wall(b, walls.north, 1.95f, 0.45f);
  add_dresser(b, m, rng, 4);
  b.pop();
  push_against_wall(b, walls.north, 3.4f, 0.44f);
  add_tv_unit(b, m);
  b.pop();
  b.push(place(Vec3(5.15f, 4.15f, 0.f)));
  add_plant(b, m, rng, 1.25f, 0.4f);
  b.pop();

  // East wall (s = depth - y): window with radiator and curtains, writing desk with a monitor and a
  // chair, a bin, a poster.
  b.push(wall_frame(walls.east));
  add_window(b, m, window, WindowStyle{});
  add_skirting(b, m, 0.f, depth);
  add_picture(b, m(MK::kPoster, 0), m(MK::kDarkMetal), 3.85f, 1.65f, 0.6f, 0.45f);
  b.push(place(Vec3(2.2f, 0.f, 0.f)));
  add_radiator(b, m, 1.1f);
  b.pop();
  b.pop();
  push_against_wall(b, walls.east, 3.85f, 0.55f);
  add_table(b, m, 1.0f, 0.55f, 0.75f, m(MK::kOakWood), m(MK::kDarkMetal), true);
  b.push(place(Vec3(0.f, 0.1f, 0.75f)));
  add_monitor(b, m, 0);
  b.pop();
  b.push(place(Vec3(-0.05f, -0.14f, 0.75f)));
  add_keyboard_and_mouse(b, m);
  b.pop();
  b.pop();
  b.push(wall_frame(walls.east) * place(Vec3(3.85f, -0.85f, 0.f), kPi));
  add_dining_chair(b, m, m(MK::kPlaidFabric));
  b.pop();
  b.push(place(Vec3(5.3f, 1.38f, 0.f)));
  add_bin(b, m);
  b.pop();

  add_pendant_lamp(b, m, 1.9f, 2.1f, height);
  add_pendant_lamp(b, m, 3.7f, 2.1f, height);

  return b.finish({light(1.9f, 2.1f, 1.95f, 1.f), light(3.7f, 2.1f, 1.95f, 1.f), light(2.8f, 3.9f, 2.4f, 0.6f)},
                  {position("SL-1", 1.9, 2.75, 0.0), position("SL-2", 3.7, 2.75, 0.5 * kPi)});
}

// ------------------------------------------------------------------------------------------------
// Office (paper: SO): 6.6 m x 5.6 m, 2.8 m high. Two desks under the south windows, two on the north
// wall either side of a whiteboard, bookshelves on the west, door with filing cabinets and a coat
// stand on the east, a round table in the middle.
Scene make_office(const SceneStyle& style) {
  const float width = 6.6f, depth = 5.6f, height = 2.8f;
  SceneBuilder b("office");
  MaterialLibrary m(b, kOfficeSeed, style.texture);
  RandomStream rng(kOfficeSeed, 0, 0, RandomPurpose::kScene, 1);
  const RoomWalls walls = room_walls(width, depth);
  const WallOpening window_east_half{1.0f, 2.4f, 0.95f, 2.25f};  // south wall, s = width - x
  const WallOpening window_west_half{4.2f, 5.6f, 0.95f, 2.25f};
  const WallOpening door{2.4f, 3.3f, 0.f, 2.1f};  // east wall, s = depth - y

  add_floor_and_ceiling(b, width, depth, height, m(MK::kCarpetTiles), m(MK::kAcousticCeiling));
  b.add_wall(walls.south.start, walls.south.end, height, {window_east_half, window_west_half}, m(MK::kBrickWall));
  b.add_wall(walls.west.start, walls.west.end, height, {}, m(MK::kGeometricWallpaper));
  b.add_wall(walls.north.start, walls.north.end, height, {}, m(MK::kBrickWall));
  b.add_wall(walls.east.start, walls.east.end, height, {door}, m(MK::kGeometricWallpaper));

  // A workstation: desk, monitor, keyboard, something else on the desk, and a chair facing the wall.
  int workstation = 0;
  auto add_workstation = [&](const Wall& wall, float s) {
    push_against_wall(b, wall, s, 0.7f);
    add_desk_with_screen(b, m, workstation % 2);
    switch (workstation) {
      case 0:
        b.push(place(Vec3(0.5f, 0.1f, 0.74f)));
        add_table_lamp(b, m);
        b.pop();
        break;
      case 1:
        b.push(place(Vec3(-0.5f, 0.05f, 0.74f), 0.3f));
        add_book_stack(b, m, rng, 5);
        b.pop();
        break;
      case 2:
        b.push(place(Vec3(0.52f, 0.1f, 0.74f)));
        add_plant(b, m, rng, 0.45f, 0.25f);
        b.pop();
        break;
      default:
        b.push(place(Vec3(-0.52f, 0.12f, 0.74f)));
        add_vase(b, m(MK::kCeramicTiles), 0.18f, 0.045f);
        b.pop();
        b.push(place(Vec3(0.5f, 0.f, 0.74f), -0.2f));
        add_book_stack(b, m, rng, 2);
        b.pop();
        break;
    }
    b.pop();
    b.push(wall_frame(wall) * place(Vec3(s, -0.95f, 0.f), kPi + 0.15f * (workstation % 2 ? 1.f : -1.f)));
    add_office_chair(b, m);
    b.pop();
    ++workstation;
  };

  // South wall (s = width - x): two windows with a desk under each.
  b.push(wall_frame(walls.south));
  WindowStyle plain;
  plain.curtains = false;
  add_window(b, m, window_east_half, plain);
  plain.outdoor_variant = 1;
  add_window(b, m, window_west_half, plain);
  add_skirting(b, m, 0.f, width);
  b.pop();
  add_workstation(walls.south, 1.7f);
  add_workstation(walls.south, 4.9f);
  b.push(place(Vec3(2.65f, 0.25f, 0.f)));
  add_bin(b, m);
  b.pop();

  // North wall (s = x): two desks, whiteboard, low cabinet with a printer.
  b.push(wall_frame(walls.north));
  add_skirting(b, m, 0.f, width);
  add_whiteboard(b, m, 3.3f, 1.5f, 1.5f, 0.95f);
  b.pop();
  add_workstation(walls.north, 1.7f);
  add_workstation(walls.north, 4.9f);
  push_against_wall(b, walls.north, 3.3f, 0.45f);
  add_chest_of_drawers(b, m, 0.8f, 0.45f, 0.68f, 2, m(MK::kDarkMetal));
  b.push(place(Vec3(0.f, 0.f, 0.7f)));
  add_printer(b, m);
  b.pop();
  b.pop();
  b.push(place(Vec3(4.0f, 5.3f, 0.f)));
  add_bin(b, m);
  b.pop();

  // West wall (s = y): two bookshelves, posters; plant in the south-west corner.
  b.push(wall_frame(walls.west));
  add_skirting(b, m, 0.f, depth);
  add_picture(b, m(MK::kPoster, 0), m(MK::kDarkMetal), 0.75f, 1.65f, 0.5f, 0.7f);
  add_picture(b, m(MK::kPoster, 1), m(MK::kOakWood), 4.6f, 1.65f, 0.6f, 0.8f);
  b.pop();
  push_against_wall(b, walls.west, 2.3f, 0.32f);
  add_bookshelf(b, m, rng, 1.0f, 2.1f, 5, m(MK::kOakWood));
  b.pop();
  push_against_wall(b, walls.west, 3.32f, 0.32f);
  add_bookshelf(b, m, rng, 1.0f, 2.1f, 5, m(MK::kOakWood));
  b.pop();
  b.push(place(Vec3(0.4f, 0.4f, 0.f)));
  add_plant(b, m, rng, 1.1f, 0.38f);
  b.pop();

  // East wall (s = depth - y): door, two filing cabinets, coat stand, poster; plants in the corners.
  b.push(wall_frame(walls.east));
  add_door(b, m, door);
  add_skirting(b, m, 0.f, door.s0 - 0.08f);
  add_skirting(b, m, door.s1 + 0.08f, depth);
  add_picture(b, m(MK::kPoster, 2), m(MK::kDarkMetal), 4.4f, 1.65f, 0.55f, 0.7f);
  b.pop();
  for (float s : {1.2f, 4.4f}) {
    push_against_wall(b, walls.east, s, 0.6f);
    add_chest_of_drawers(b, m, 0.5f, 0.6f, 1.0f, 3, m(MK::kDarkMetal));
    b.pop();
  }
  b.push(place(Vec3(6.25f, 1.85f, 0.f)));
  add_coat_stand(b, m);
  b.pop();
  b.push(place(Vec3(6.2f, 0.4f, 0.f)));
  add_plant(b, m, rng, 1.2f, 0.38f);
  b.pop();
  b.push(place(Vec3(6.2f, 5.2f, 0.f)));
  add_plant(b, m, rng, 0.9f, 0.38f);
  b.pop();

  // Middle: a small round table with a plant and books.
  b.push(place(Vec3(3.3f, 2.8f, 0.f)));
  add_round_table(b, m, 0.42f, 0.72f, m(MK::kOakWood));
  b.push(place(Vec3(0.1f, 0.08f, 0.72f)));
  add_plant(b, m, rng, 0.4f, 0.35f);
  b.pop();
  b.push(place(Vec3(-0.15f, -0.12f, 0.72f), 1.1f));
  add_book_stack(b, m, rng, 2);
  b.pop();
  b.pop();

  const float panel_x[2] = {2.3f, 4.3f}, panel_y[2] = {2.0f, 3.6f};
  std::vector<PointLight> lights;
  for (float x : panel_x)
    for (float y : panel_y) {
      add_ceiling_panel_light(b, m, x, y, height);
      lights.push_back(light(x, y, height - 0.35f, 0.8f));
    }

  return b.finish(lights, {position("SO-1", 2.3, 2.0, 0.0), position("SO-2", 4.3, 3.6, 0.5 * kPi),
                           position("SO-3", 2.3, 3.6, kPi), position("SO-4", 4.3, 2.0, 1.5 * kPi)});
}

}  // namespace

std::vector<std::string> builtin_scene_names() { return {"living_room", "office"}; }

bool is_builtin_scene(const std::string& name) {
  for (const std::string& known : builtin_scene_names())
    if (known == name) return true;
  return false;
}

std::vector<std::string> texture_density_names() { return {"icl", "rich", "plain"}; }

std::string to_string(TextureDensity density) {
  switch (density) {
    case TextureDensity::kIcl: return "icl";
    case TextureDensity::kRich: return "rich";
    case TextureDensity::kPlain: return "plain";
  }
  return "icl";
}

TextureDensity texture_density_from_string(const std::string& value, const std::string& field) {
  if (value == "icl") return TextureDensity::kIcl;
  if (value == "rich") return TextureDensity::kRich;
  if (value == "plain") return TextureDensity::kPlain;
  throw make_error("", field, "unknown texture density '" + value + "' (known: icl, rich, plain)");
}

SceneStyle scene_style_from_config(Config& config) {
  SceneStyle style;
  style.texture = texture_density_from_string(config.get_string("scene.texture", "icl", texture_density_names()));
  return style;
}

Scene make_builtin_scene(const std::string& name, const SceneStyle& style) {
  if (name == "living_room") return make_living_room(style);
  if (name == "office") return make_office(style);
  std::string known;
  for (const std::string& n : builtin_scene_names()) known += (known.empty() ? "" : ", ") + n;
  throw make_error("", "scene", "unknown built-in scene '" + name + "' (known: " + known + ")");
}

}  // namespace panoscan::scenes
