// The seeded room generator (scenes.h): a rectangular or L-shaped room with doors and windows,
// furniture of the built-in scenes' library placed without intersections, and scanning positions
// in free space chosen with exact queries on the finished mesh.
//
// Placement: every piece is drawn where it is tried, its bounding box taken from the triangles it
// produced; a piece that leaves the floor plan or meets a placed piece, a door's swing or a window
// is taken out again (SceneBuilder::truncate). So the non-intersection test is on the real
// geometry's boxes, not on nominal sizes.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "furniture.h"
#include "materials.h"
#include "mesh_query.h"
#include "panoscan/core/error.h"
#include "panoscan/core/random.h"
#include "panoscan/scenes/scenes.h"
#include "scene_builder.h"

namespace panoscan::scenes {

namespace {

constexpr float kPi = 3.14159265358979323846f;
using MK = MaterialKind;

struct Box3 {
  Vec3 lo, hi;
  bool overlaps(const Box3& o, float margin) const {
    for (int k = 0; k < 3; ++k)
      if (lo[k] >= o.hi[k] + margin || o.lo[k] >= hi[k] + margin) return false;
    return true;
  }
};

// A box given in a wall frame (x along the wall, y into it, z up), in the scene frame.
Box3 wall_box(const Wall& wall, const Vec3& lo, const Vec3& hi) {
  const Pose3 frame = wall_frame(wall);
  Box3 box{Vec3::Constant(1e30f), Vec3::Constant(-1e30f)};
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(), (corner & 4) ? hi.z() : lo.z());
    const Vec3 q = frame * p;
    box.lo = box.lo.cwiseMin(q);
    box.hi = box.hi.cwiseMax(q);
  }
  return box;
}

// The floor plan: a W x D rectangle, less the notch [W - cw, W] x [D - cd, D] for an L.
struct Plan {
  float width = 0.f, depth = 0.f, height = 0.f;
  float notch_w = 0.f, notch_d = 0.f;         // 0 for a rectangle
  std::vector<Vec2> outline;                  // counter-clockwise seen from above
  std::vector<std::pair<Vec2, Vec2>> pieces;  // floor rectangles (min, max) without T-junctions

  bool is_l() const { return notch_w > 0.f; }
  // Is the rectangle [lo, hi] (xy) inside the plan, `margin` from its walls?
  bool contains(const Vec2& lo, const Vec2& hi, float margin = 0.f) const {
    if (lo.x() < margin || lo.y() < margin || hi.x() > width - margin || hi.y() > depth - margin) return false;
    if (!is_l()) return true;
    const bool in_notch_x = hi.x() > width - notch_w - margin, in_notch_y = hi.y() > depth - notch_d - margin;
    return !(in_notch_x && in_notch_y);
  }
  double area() const { return double(width) * depth - double(notch_w) * notch_d; }
};

Plan make_plan(RandomStream& rng) {
  Plan plan;
  plan.height = float(rng.uniform(2.4, 3.0));
  if (rng.uniform() < 0.4) {
    plan.width = float(rng.uniform(5.0, 8.0));
    plan.depth = float(rng.uniform(4.5, 8.0));
    plan.notch_w = float(rng.uniform(0.3, 0.45)) * plan.width;
    plan.notch_d = float(rng.uniform(0.3, 0.45)) * plan.depth;
    const float w = plan.width, d = plan.depth, xw = w - plan.notch_w, yd = d - plan.notch_d;
    plan.outline = {Vec2(0, 0), Vec2(w, 0), Vec2(w, yd), Vec2(xw, yd), Vec2(xw, d), Vec2(0, d)};
    plan.pieces = {{Vec2(0, 0), Vec2(xw, yd)}, {Vec2(xw, 0), Vec2(w, yd)}, {Vec2(0, yd), Vec2(xw, d)}};
  } else {
    plan.width = float(rng.uniform(3.2, 8.0));
    plan.depth = float(rng.uniform(3.0, 8.0));
    const float w = plan.width, d = plan.depth;
    plan.outline = {Vec2(0, 0), Vec2(w, 0), Vec2(w, d), Vec2(0, d)};
    plan.pieces = {{Vec2(0, 0), Vec2(w, d)}};
  }
  return plan;
}

// A piece of furniture against a wall: its footprint's width along the wall and its depth; drawn in
// its own frame (footprint-centred, front towards -y, back to the wall).
struct Piece {
  std::string name;
  float width = 1.f, depth = 0.5f;
  std::function<void(SceneBuilder&, MaterialLibrary&, RandomStream&)> draw;
};

// A picture-like fixture on a wall: width and height, centred at height t.
struct Decoration {
  std::string name;
  float width = 0.5f, height = 0.7f, t = 1.65f;
  std::function<void(SceneBuilder&, MaterialLibrary&, float s)> draw;  // in the wall frame
};

std::vector<Piece> office_pieces(RandomStream& rng, float height) {
  std::vector<Piece> pieces;
  const int desks = rng.uniform_int(2, 4);
  for (int k = 0; k < desks; ++k)
    pieces.push_back({"workstation", 1.4f, 1.4f, [k](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                        b.push(place(Vec3(0.f, 0.35f, 0.f)));
                        add_desk_with_screen(b, m, k % 2);
                        if (k % 2 == 0) {
                          b.push(place(Vec3(0.5f, 0.1f, 0.74f)));
                          add_table_lamp(b, m);
                        } else {
                          b.push(place(Vec3(-0.5f, 0.05f, 0.74f), 0.3f));
                          add_book_stack(b, m, r, 3);
                        }
                        b.pop();
                        b.push(place(Vec3(0.f, -0.59f, 0.f), kPi + (k % 2 ? 0.15f : -0.15f)));
                        add_office_chair(b, m);
                        b.pop();
                        b.pop();
                      }});
  const float shelf_height = std::min(2.1f, height - 0.2f);
  const int shelves = rng.uniform_int(1, 2);
  for (int k = 0; k < shelves; ++k)
    pieces.push_back({"bookshelf", 1.0f, 0.32f, [shelf_height](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                        add_bookshelf(b, m, r, 1.0f, shelf_height, 5, m(MK::kOakWood));
                      }});
  pieces.push_back({"filing_cabinet", 0.5f, 0.6f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) {
                      add_chest_of_drawers(b, m, 0.5f, 0.6f, 1.0f, 3, m(MK::kDarkMetal));
                    }});
  pieces.push_back({"printer_cabinet", 0.8f, 0.45f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) {
                      add_chest_of_drawers(b, m, 0.8f, 0.45f, 0.68f, 2, m(MK::kDarkMetal));
                      b.push(place(Vec3(0.f, 0.f, 0.7f)));
                      add_printer(b, m);
                      b.pop();
                    }});
  const int plants = rng.uniform_int(1, 2);
  for (int k = 0; k < plants; ++k)
    pieces.push_back({"plant", 0.8f, 0.8f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                        add_plant(b, m, r, float(r.uniform(0.9, 1.2)), 0.38f);
                      }});
  pieces.push_back(
      {"coat_stand", 0.5f, 0.5f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) { add_coat_stand(b, m); }});
  pieces.push_back({"bin", 0.32f, 0.32f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) { add_bin(b, m); }});
  return pieces;
}

std::vector<Piece> living_room_pieces(RandomStream& rng, float height) {
  std::vector<Piece> pieces;
  // The sofa with a rug and a coffee table in front of it.
  pieces.push_back({"sofa", 2.6f, 2.4f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                      b.push(place(Vec3(0.f, 0.75f, 0.f)));
                      add_sofa(b, m, 2.1f, m(MK::kUpholsteryBlue), m(MK::kPlaidFabric));
                      b.push(place(Vec3(0.f, -1.35f, 0.f)));
                      add_rug(b, m, 2.4f, 1.5f);
                      b.pop();
                      b.push(place(Vec3(0.f, -1.4f, 0.f)));
                      add_round_table(b, m, 0.4f, 0.42f, m(MK::kOakWood));
                      b.push(place(Vec3(0.12f, -0.08f, 0.42f), 0.4f));
                      add_book_stack(b, m, r, 3);
                      b.pop();
                      b.pop();
                      b.pop();
                    }});
  pieces.push_back(
      {"tv_unit", 1.6f, 0.45f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) { add_tv_unit(b, m); }});
  const float shelf_height = std::min(2.0f, height - 0.2f);
  pieces.push_back({"bookshelf", 1.2f, 0.32f, [shelf_height](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                      add_bookshelf(b, m, r, 1.2f, shelf_height, 5, m(MK::kWalnutWood));
                    }});
  pieces.push_back({"chest_of_drawers", 0.8f, 0.45f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                      add_dresser(b, m, r, 3);
                    }});
  pieces.push_back({"armchair", 0.9f, 0.9f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) {
                      add_armchair(b, m, m(MK::kUpholsteryOchre));
                    }});
  pieces.push_back({"writing_desk", 1.0f, 1.15f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) {
                      b.push(place(Vec3(0.f, 0.3f, 0.f)));
                      add_table(b, m, 1.0f, 0.55f, 0.75f, m(MK::kOakWood), m(MK::kDarkMetal), true);
                      b.push(place(Vec3(0.f, 0.1f, 0.75f)));
                      add_monitor(b, m, 0);
                      b.pop();
                      b.push(place(Vec3(-0.05f, -0.14f, 0.75f)));
                      add_keyboard_and_mouse(b, m);
                      b.pop();
                      b.push(place(Vec3(0.f, -0.55f, 0.f), kPi));
                      add_dining_chair(b, m, m(MK::kPlaidFabric));
                      b.pop();
                      b.pop();
                    }});
  pieces.push_back({"side_table", 0.5f, 0.5f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) {
                      add_round_table(b, m, 0.25f, 0.55f, m(MK::kWalnutWood));
                      b.push(place(Vec3(0.f, 0.f, 0.55f)));
                      add_table_lamp(b, m);
                      b.pop();
                    }});
  pieces.push_back(
      {"floor_lamp", 0.46f, 0.46f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream&) { add_floor_lamp(b, m); }});
  const int plants = rng.uniform_int(1, 2);
  for (int k = 0; k < plants; ++k)
    pieces.push_back({"plant", 0.84f, 0.84f, [](SceneBuilder& b, MaterialLibrary& m, RandomStream& r) {
                        add_plant(b, m, r, float(r.uniform(1.0, 1.25)), 0.4f);
                      }});
  return pieces;
}

std::vector<Decoration> decorations(RoomKind kind, RandomStream& rng) {
  std::vector<Decoration> list;
  if (kind == RoomKind::kOffice)
    list.push_back({"whiteboard", 1.5f, 0.95f, 1.5f,
                    [](SceneBuilder& b, MaterialLibrary& m, float s) { add_whiteboard(b, m, s, 1.5f, 1.5f, 0.95f); }});
  const int posters = kind == RoomKind::kOffice ? rng.uniform_int(1, 3) : rng.uniform_int(2, 4);
  for (int k = 0; k < posters; ++k) {
    const float w = float(rng.uniform(0.45, 0.8)), h = float(rng.uniform(0.45, 0.8));
    const MK frame = k % 3 == 0 ? MK::kDarkMetal : (k % 3 == 1 ? MK::kOakWood : MK::kWalnutWood);
    list.push_back(
        {"poster", w + 0.07f, h + 0.07f, 1.65f, [k, w, h, frame](SceneBuilder& b, MaterialLibrary& m, float s) {
           add_picture(b, m(MK::kPoster, k % 4), m(frame), s, 1.65f, w, h);
         }});
  }
  return list;
}

// Evenly spread unit directions (Fibonacci sphere).
std::vector<Eigen::Vector3d> sphere_directions(int n) {
  std::vector<Eigen::Vector3d> directions;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n, r = std::sqrt(1.0 - z * z), phi = i * 2.399963229728653;
    directions.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return directions;
}

// Share of what `a` sees (surface points hit by evenly spread rays) that `b` sees too.
double seen_from_both(const MeshQuery& query, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const std::vector<Eigen::Vector3d>& directions) {
  int hits = 0, shared = 0;
  for (const Eigen::Vector3d& d : directions) {
    const double t = query.first_hit(a, d);
    if (t <= 0) continue;
    ++hits;
    const Eigen::Vector3d p = a + t * d;
    const Eigen::Vector3d to_p = p - b;
    const double distance = to_p.norm();
    if (distance < 1e-6) continue;
    if (query.first_hit(b, to_p / distance, distance - 0.02) < 0) ++shared;
  }
  return hits ? double(shared) / hits : 0.0;
}

constexpr double kRigHeight = 1.1;  // the sensors' height above the floor
constexpr double kAxisTop = 1.5;    // the rig's extent checked for clearance
constexpr double kClearance = 0.6;  // axis to any surface: the cameras, <= 0.09 m off the axis, stay >= 0.5 m away
constexpr double kMinNeighbour = 1.5, kMaxNeighbour = 3.0;
constexpr double kMinSharedView = 0.6;

double axis_clearance(const MeshQuery& obstacles, double x, double y, double cap) {
  double clearance = cap;
  for (double h = 0.05; h <= kAxisTop + 1e-9; h += 0.05) {
    clearance = std::min(clearance, obstacles.distance(Eigen::Vector3d(x, y, h), clearance));
    if (clearance < kClearance) break;
  }
  return clearance;
}

}  // namespace

std::vector<std::string> room_kind_names() { return {"office", "living_room"}; }

std::string to_string(RoomKind kind) { return kind == RoomKind::kOffice ? "office" : "living_room"; }

RoomKind room_kind_from_string(const std::string& value, const std::string& field) {
  if (value == "office") return RoomKind::kOffice;
  if (value == "living_room") return RoomKind::kLivingRoom;
  throw make_error("", field, "unknown room kind '" + value + "' (known: office, living_room)");
}

std::string generated_room_name(const RoomSpec& spec) {
  return to_string(spec.kind) + "_seed" + std::to_string(spec.seed);
}

GeneratedRoom generate_room(const RoomSpec& spec) {
  const int kind_index = spec.kind == RoomKind::kOffice ? 1 : 2;
  const std::vector<Eigen::Vector3d> directions = sphere_directions(300);
  for (int attempt = 0; attempt < 24; ++attempt) {
    RandomStream rng(spec.seed, kind_index, attempt, RandomPurpose::kScene, 7);
    RandomStream furniture_rng(spec.seed, kind_index, attempt, RandomPurpose::kScene, 8);
    GeneratedRoom room;
    Plan plan = make_plan(rng);
    room.outline = plan.outline;
    room.height = plan.height;
    SceneBuilder b(generated_room_name(spec));
    MaterialLibrary m(b, mix64(spec.seed * 4 + std::uint64_t(kind_index)), spec.style.texture);
    const bool office = spec.kind == RoomKind::kOffice;

    // Shell: floor and ceiling pieces, walls clockwise seen from above (each seen from inside).
    const int floor = m(office ? MK::kCarpetTiles : MK::kParquetFloor);
    const int ceiling = m(office ? MK::kAcousticCeiling : MK::kCofferedCeiling);
    const float H = plan.height;
    for (const auto& [lo, hi] : plan.pieces) {
      b.add_quad(Vec3(lo.x(), lo.y(), 0.f), Vec3(hi.x(), lo.y(), 0.f), Vec3(hi.x(), hi.y(), 0.f),
                 Vec3(lo.x(), hi.y(), 0.f), floor);
      b.add_quad(Vec3(lo.x(), lo.y(), H), Vec3(lo.x(), hi.y(), H), Vec3(hi.x(), hi.y(), H), Vec3(hi.x(), lo.y(), H),
                 ceiling);
    }
    std::vector<Wall> walls;
    for (std::size_t i = 0; i < plan.outline.size(); ++i)
      walls.push_back(Wall{plan.outline[(i + 1) % plan.outline.size()], plan.outline[i]});

    // Openings: a door, then one to three windows, each clear of the corners and of each other.
    std::vector<std::vector<WallOpening>> openings(walls.size());
    std::vector<int> door_wall;
    std::vector<Box3> obstacles;  // door swings, windows, placed pieces
    auto free_on_wall = [&](std::size_t w, float s0, float s1) {
      for (const WallOpening& o : openings[w])
        if (s0 < o.s1 + 0.3f && o.s0 < s1 + 0.3f) return false;
      return true;
    };
    auto pick_wall = [&](float min_length) {
      for (int tries = 0; tries < 32; ++tries) {
        const std::size_t w = std::size_t(rng.uniform_int(0, int(walls.size()) - 1));
        if (walls[w].length() >= min_length) return int(w);
      }
      return -1;
    };
    {
      const int w = pick_wall(1.7f);
      if (w < 0) continue;
      const float length = walls[std::size_t(w)].length();
      const float s0 = float(rng.uniform(0.35, length - 1.25));
      openings[std::size_t(w)].push_back(WallOpening{s0, s0 + 0.9f, 0.f, 2.05f});
      door_wall.push_back(w);
    }
    const int windows = rng.uniform_int(1, office ? 3 : 2);
    for (int k = 0; k < windows; ++k)
      for (int tries = 0; tries < 16; ++tries) {
        const int w = pick_wall(2.0f);
        if (w < 0) break;
        const float length = walls[std::size_t(w)].length();
        const float width = float(rng.uniform(1.0, std::min(1.8, length - 0.9)));
        const float s0 = float(rng.uniform(0.45, length - 0.45 - width));
        const float sill = float(rng.uniform(0.85, 0.95)), top = std::min(H - 0.25f, 2.25f);
        if (!free_on_wall(std::size_t(w), s0, s0 + width)) continue;
        openings[std::size_t(w)].push_back(WallOpening{s0, s0 + width, sill, top});
        break;
      }
    const MK wall_kinds[2] = {office ? MK::kBrickWall : MK::kDamaskWallpaper,
                              office ? MK::kGeometricWallpaper : MK::kStripedWallpaper};
    int outdoor_variant = 0;
    for (std::size_t w = 0; w < walls.size(); ++w) {
      const Wall& wall = walls[w];
      b.add_wall(wall.start, wall.end, H, openings[w], m(wall_kinds[w % 2]));
      b.push(wall_frame(wall));
      std::vector<std::pair<float, float>> skirting = {{0.f, wall.length()}};
      for (const WallOpening& o : openings[w]) {
        const std::size_t first = b.num_triangles();
        if (o.t0 == 0.f) {
          add_door(b, m, o);
          // The door leaf swings into the room: keep a metre in front of it clear.
          obstacles.push_back(wall_box(wall, Vec3(o.s0 - 0.15f, -1.0f, 0.f), Vec3(o.s1 + 0.15f, 0.f, o.t1)));
          std::vector<std::pair<float, float>> cut;
          for (const auto& [a, c] : skirting) {
            if (a < o.s0 - 0.08f) cut.emplace_back(a, std::min(c, o.s0 - 0.08f));
            if (c > o.s1 + 0.08f) cut.emplace_back(std::max(a, o.s1 + 0.08f), c);
          }
          skirting = cut;
        } else {
          WindowStyle style;
          style.curtains = !office;
          style.outdoor_variant = outdoor_variant++ % 2;
          add_window(b, m, o, style);
          obstacles.push_back(wall_box(wall, Vec3(o.s0, -0.3f, o.t0), Vec3(o.s1, 0.f, o.t1)));
        }
        Vec3 lo, hi;
        if (b.bounds_since(first, &lo, &hi)) obstacles.push_back(Box3{lo, hi});
      }
      for (const auto& [a, c] : skirting)
        if (c - a > 0.05f) add_skirting(b, m, a, c);
      b.pop();
    }

    // Furniture against the walls, tried at random places until it fits.
    std::vector<Piece> pieces = office ? office_pieces(rng, H) : living_room_pieces(rng, H);
    for (const Piece& piece : pieces) {
      for (int tries = 0; tries < 24; ++tries) {
        const std::size_t w = std::size_t(rng.uniform_int(0, int(walls.size()) - 1));
        const float length = walls[w].length();
        if (length < piece.width + 0.1f) continue;
        const float s = float(rng.uniform(0.5 * piece.width + 0.05, length - 0.5 * piece.width - 0.05));
        const std::size_t first = b.num_triangles();
        b.push(wall_frame(walls[w]) * place(Vec3(s, -0.5f * piece.depth - 0.01f, 0.f)));
        piece.draw(b, m, furniture_rng);
        b.pop();
        Vec3 lo, hi;
        bool fits =
            b.bounds_since(first, &lo, &hi) && plan.contains(lo.head<2>(), hi.head<2>(), 0.005f) && hi.z() < H - 0.05f;
        const Box3 box{lo, hi};
        for (std::size_t o = 0; fits && o < obstacles.size(); ++o) fits = !box.overlaps(obstacles[o], 0.05f);
        if (!fits) {
          b.truncate(first);
          continue;
        }
        obstacles.push_back(box);
        room.furniture.push_back({piece.name, lo, hi});
        break;
      }
    }
    // Pictures and a whiteboard on free stretches of wall.
    for (const Decoration& decoration : decorations(spec.kind, rng)) {
      for (int tries = 0; tries < 24; ++tries) {
        const std::size_t w = std::size_t(rng.uniform_int(0, int(walls.size()) - 1));
        const float length = walls[w].length();
        if (length < decoration.width + 0.3f) continue;
        const float s = float(rng.uniform(0.5 * decoration.width + 0.15, length - 0.5 * decoration.width - 0.15));
        const std::size_t first = b.num_triangles();
        b.push(wall_frame(walls[w]));
        decoration.draw(b, m, s);
        b.pop();
        Vec3 lo, hi;
        bool fits = b.bounds_since(first, &lo, &hi) && hi.z() < H - 0.05f;
        const Box3 box{lo, hi};
        for (std::size_t o = 0; fits && o < obstacles.size(); ++o) fits = !box.overlaps(obstacles[o], 0.03f);
        if (!fits) {
          b.truncate(first);
          continue;
        }
        obstacles.push_back(box);
        room.furniture.push_back({decoration.name, lo, hi});
        break;
      }
    }

    // Ceiling lights: one per cell of about 2.5 m over each floor piece.
    std::vector<PointLight> lights;
    for (const auto& [lo, hi] : plan.pieces) {
      const Vec2 size = hi - lo;
      const int nx = std::max(1, int(std::lround(size.x() / 2.5f))),
                ny = std::max(1, int(std::lround(size.y() / 2.5f)));
      for (int i = 0; i < nx; ++i)
        for (int j = 0; j < ny; ++j) {
          const float x = lo.x() + size.x() * (i + 0.5f) / nx, y = lo.y() + size.y() * (j + 0.5f) / ny;
          PointLight light;
          if (office) {
            add_ceiling_panel_light(b, m, x, y, H);
            light.position = Vec3(x, y, H - 0.35f);
            light.intensity = 0.8f;
          } else {
            add_pendant_lamp(b, m, x, y, H);
            light.position = Vec3(x, y, H - 0.7f);
            light.intensity = 1.f;
          }
          lights.push_back(light);
        }
    }

    Scene scene = b.finish(lights, {});

    // Scanning positions: grid points whose rig axis is clear of every surface above the floor
    // covering, chained so that each is 1.5-3 m from the previous one and both see most of the
    // same surfaces.
    const MeshQuery all(scene.mesh);
    const MeshQuery above_floor(scene.mesh, [&](std::size_t t) {
      const Eigen::Vector3i& tri = scene.mesh.triangles[t];
      return std::max({scene.mesh.vertices[tri[0]].z(), scene.mesh.vertices[tri[1]].z(),
                       scene.mesh.vertices[tri[2]].z()}) >= 0.03f;
    });
    std::vector<Eigen::Vector2d> free;
    const double step = 0.15;
    for (double x = kClearance; x <= plan.width - kClearance + 1e-9; x += step)
      for (double y = kClearance; y <= plan.depth - kClearance + 1e-9; y += step) {
        if (!plan.contains(Vec2(float(x), float(y)), Vec2(float(x), float(y)), float(kClearance))) continue;
        if (axis_clearance(above_floor, x, y, kClearance + 0.01) >= kClearance) free.emplace_back(x, y);
      }
    if (free.size() < 2) continue;
    // A seeded shuffle (Fisher-Yates with our own stream: the same on every standard library).
    for (std::size_t i = free.size() - 1; i > 0; --i) std::swap(free[i], free[std::size_t(rng.uniform_int(0, int(i)))]);
    const int wanted = std::clamp(int(std::lround(plan.area() / 9.0)) + rng.uniform_int(0, 1), 2, 6);
    auto eye = [](const Eigen::Vector2d& p) { return Eigen::Vector3d(p.x(), p.y(), kRigHeight); };
    std::vector<Eigen::Vector2d> best;
    std::vector<double> best_shared;
    for (std::size_t start = 0; start < std::min<std::size_t>(free.size(), 12) && int(best.size()) < wanted; ++start) {
      std::vector<Eigen::Vector2d> chain = {free[start]};
      std::vector<double> shared;
      while (int(chain.size()) < wanted) {
        int tried = 0;
        bool extended = false;
        for (const Eigen::Vector2d& c : free) {
          const double d = (c - chain.back()).norm();
          if (d < kMinNeighbour || d > kMaxNeighbour) continue;
          bool far_enough = true;
          for (const Eigen::Vector2d& p : chain) far_enough = far_enough && (c - p).norm() >= kMinNeighbour;
          if (!far_enough) continue;
          if (++tried > 24) break;
          const double s = std::min(seen_from_both(all, eye(chain.back()), eye(c), directions),
                                    seen_from_both(all, eye(c), eye(chain.back()), directions));
          if (s < kMinSharedView) continue;
          chain.push_back(c);
          shared.push_back(s);
          extended = true;
          break;
        }
        if (!extended) break;
      }
      if (chain.size() > best.size()) {
        best = chain;
        best_shared = shared;
      }
    }
    if (best.size() < 2) continue;
    const std::string prefix = office ? "GO-" : "GL-";
    for (std::size_t i = 0; i < best.size(); ++i) {
      ScanPosition position;
      position.name = prefix + std::to_string(i + 1);
      position.floor_point = Eigen::Vector3d(best[i].x(), best[i].y(), 0.0);
      position.start_heading_rad = rng.uniform(0.0, 2.0 * kPi);
      scene.positions.push_back(position);
      room.clearance_m.push_back(axis_clearance(above_floor, best[i].x(), best[i].y(), 10.0));
    }
    room.shared_view = best_shared;
    room.attempt = attempt;
    room.scene = std::move(scene);
    room.scene.check("<generated " + room.scene.name + ">");
    return room;
  }
  throw make_error(generated_room_name(spec), "seed", "no room with room for two scanning positions in 24 attempts");
}

}  // namespace panoscan::scenes
