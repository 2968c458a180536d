#include "furniture.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace panoscan::scenes {

namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kHalfPi = 0.5f * kPi;

using MK = MaterialKind;

float draw(RandomStream& rng, float lo, float hi) { return static_cast<float>(rng.uniform(lo, hi)); }

// A profile in the (y, z) plane with straight sides from z_bottom to z_shoulder and a half-round
// top of radius half_width: counter-clockwise seen from +x (for add_prism). Sofa arms, a mouse.
std::vector<Vec2> rounded_top_profile(float half_width, float z_bottom, float z_shoulder, int arc_segments = 10) {
  std::vector<Vec2> profile = {Vec2(half_width, z_bottom), Vec2(half_width, z_shoulder)};
  for (int k = 1; k < arc_segments; ++k) {
    const float a = kPi * static_cast<float>(k) / static_cast<float>(arc_segments);
    profile.emplace_back(half_width * std::cos(a), z_shoulder + half_width * std::sin(a));
  }
  profile.emplace_back(-half_width, z_shoulder);
  profile.emplace_back(-half_width, z_bottom);
  return profile;
}

// Points on a circular arc in the xy plane (for curved chair backs).
std::vector<Vec2> arc_path(const Vec2& centre, float radius, float angle0, float angle1, int segments) {
  std::vector<Vec2> path;
  for (int k = 0; k <= segments; ++k) {
    const float a = angle0 + (angle1 - angle0) * static_cast<float>(k) / static_cast<float>(segments);
    path.emplace_back(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a));
  }
  return path;
}

// One book standing upright, spine towards -y: [x0, x0 + thickness] x [y_front, y_front + depth] x
// [z0, z0 + height]. Covers are cloth (the spine atlas), edges are pages, the spine face shows one
// column of the atlas.
void add_book(SceneBuilder& b, MaterialLibrary& m, float x0, float thickness, float y_front, float depth, float z0,
              float height, int spine_column) {
  const Vec3 lo(x0, y_front, z0), hi(x0 + thickness, y_front + depth, z0 + height);
  b.add_box(lo, hi, m(MK::kBookSpines), kFaceMinX | kFaceMaxX);
  b.add_box(lo, hi, m(MK::kPaperEdges), kFaceMinZ | kFaceMaxZ | kFaceMaxY);
  const float u0 = static_cast<float>(spine_column) / 16.f;
  b.add_fitted_quad(Vec3(lo.x(), lo.y(), lo.z()), Vec3(hi.x(), lo.y(), lo.z()), Vec3(hi.x(), lo.y(), hi.z()),
                    Vec3(lo.x(), lo.y(), hi.z()), m(MK::kBookSpines), Vec2(u0, 0.f), Vec2(u0 + 1.f / 16.f, 1.f));
}

// One book lying flat, spine towards -y: [x0, x0 + length] x [y_front, y_front + depth] x [z0, z0 + thickness].
void add_lying_book(SceneBuilder& b, MaterialLibrary& m, float x0, float length, float y_front, float depth, float z0,
                    float thickness, int spine_column) {
  const Vec3 lo(x0, y_front, z0), hi(x0 + length, y_front + depth, z0 + thickness);
  b.add_box(lo, hi, m(MK::kBookSpines), kFaceMinZ | kFaceMaxZ);
  b.add_box(lo, hi, m(MK::kPaperEdges), kFaceMinX | kFaceMaxX | kFaceMaxY);
  const float u0 = static_cast<float>(spine_column) / 16.f;
  // The same quad as for a standing book, its corners listed from a different start so that the
  // atlas column runs along the book's length.
  b.add_fitted_quad(Vec3(hi.x(), lo.y(), lo.z()), Vec3(hi.x(), lo.y(), hi.z()), Vec3(lo.x(), lo.y(), hi.z()),
                    Vec3(lo.x(), lo.y(), lo.z()), m(MK::kBookSpines), Vec2(u0, 0.f), Vec2(u0 + 1.f / 16.f, 1.f));
}

// A flat leaf from `base` pointing along plan direction `heading` (radians), drooping by `droop`.
void add_leaf(SceneBuilder& b, int material, const Vec3& base, float heading, float droop, float length, float width) {
  std::vector<Vec2> profile;  // pointed lens in (y, z): y along the leaf, z across the blade
  const int n = 8;
  for (int i = 0; i <= n; ++i) {
    const float y = length * static_cast<float>(i) / n;
    profile.emplace_back(y, -0.5f * width * std::sin(kPi * static_cast<float>(i) / n));
  }
  for (int i = n - 1; i >= 1; --i) {
    const float y = length * static_cast<float>(i) / n;
    profile.emplace_back(y, 0.5f * width * std::sin(kPi * static_cast<float>(i) / n));
  }
  // Point local +y along the heading, pitch it down, then turn the blade flat about its length.
  b.push(place(base, heading - kHalfPi) * tilt_x(Vec3::Zero(), -droop) * tilt_y(Vec3::Zero(), 1.25f));
  b.add_prism(profile, -0.002f, 0.002f, material);
  b.pop();
}

}  // namespace

Pose3 wall_frame(const Wall& wall) {
  const Vec2 d = (wall.end - wall.start).normalized();
  const Vec3 along(d.x(), d.y(), 0.f);
  Pose3 pose = Pose3::Identity();
  pose.linear().col(0) = along;
  pose.linear().col(1) = Vec3::UnitZ().cross(along);  // into the wall, away from the room
  pose.linear().col(2) = Vec3::UnitZ();
  pose.translation() = Vec3(wall.start.x(), wall.start.y(), 0.f);
  return pose;
}

// ------------------------------------------------------------------------------------------------
// Fixtures (wall frame: x along the wall, y into the wall, z up).

void add_window(SceneBuilder& b, MaterialLibrary& m, const WallOpening& o, const WindowStyle& style) {
  const float d = style.recess_depth;
  const int trim = m(MK::kTrimPaint);
  // The recess closes the hole in the wall: four reveals and the view out at its back, so that no
  // ray leaves the room.
  b.add_inward_box(Vec3(o.s0, 0.f, o.t0), Vec3(o.s1, d, o.t1), m(MK::kPlaster),
                   kFaceMinX | kFaceMaxX | kFaceMinZ | kFaceMaxZ);
  b.add_fitted_quad(Vec3(o.s0, d, o.t0), Vec3(o.s1, d, o.t0), Vec3(o.s1, d, o.t1), Vec3(o.s0, d, o.t1),
                    m(MK::kOutdoorView, style.outdoor_variant));
  // Casement frame, mullion and transom a little in front of the view.
  const float fw = 0.06f, y0 = d - 0.09f, y1 = d - 0.03f;
  b.add_box(Vec3(o.s0, y0, o.t0), Vec3(o.s0 + fw, y1, o.t1), trim);
  b.add_box(Vec3(o.s1 - fw, y0, o.t0), Vec3(o.s1, y1, o.t1), trim);
  b.add_box(Vec3(o.s0 + fw, y0, o.t0), Vec3(o.s1 - fw, y1, o.t0 + fw), trim);
  b.add_box(Vec3(o.s0 + fw, y0, o.t1 - fw), Vec3(o.s1 - fw, y1, o.t1), trim);
  const float sm = 0.5f * (o.s0 + o.s1), transom = o.t0 + 0.66f * (o.t1 - o.t0);
  b.add_box(Vec3(sm - 0.03f, y0 + 0.01f, o.t0 + fw), Vec3(sm + 0.03f, y1, o.t1 - fw), trim);
  b.add_box(Vec3(o.s0 + fw, y0 + 0.01f, transom - 0.025f), Vec3(o.s1 - fw, y1, transom + 0.025f), trim);
  // Sill and architrave.
  b.add_box(Vec3(o.s0 - 0.06f, -0.06f, o.t0 - 0.035f), Vec3(o.s1 + 0.06f, 0.03f, o.t0 + 0.01f), m(MK::kCeramicTiles));
  b.add_box(Vec3(o.s0 - 0.07f, -0.02f, o.t0 - 0.035f), Vec3(o.s0, 0.f, o.t1 + 0.07f), trim, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(o.s1, -0.02f, o.t0 - 0.035f), Vec3(o.s1 + 0.07f, 0.f, o.t1 + 0.07f), trim, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(o.s0, -0.02f, o.t1), Vec3(o.s1, 0.f, o.t1 + 0.07f), trim, kAllFaces & ~kFaceMaxY);
  if (!style.curtains) return;
  // Curtains: gathered folds (a wavy slab) on both sides, from a rod above the window.
  const float rod_t = o.t1 + 0.16f, curtain_y = -0.11f;
  b.add_rod(Vec3(o.s0 - 0.5f, curtain_y, rod_t), Vec3(o.s1 + 0.5f, curtain_y, rod_t), 0.012f, 12, m(MK::kDarkMetal));
  for (float end : {o.s0 - 0.5f, o.s1 + 0.5f})
    b.add_lathe(Vec3(end, curtain_y, rod_t - 0.025f),
                {Vec2(0.f, 0.f), Vec2(0.02f, 0.01f), Vec2(0.025f, 0.025f), Vec2(0.02f, 0.04f), Vec2(0.f, 0.05f)}, 16,
                m(MK::kDarkMetal));
  for (int side = 0; side < 2; ++side) {
    const float a = side == 0 ? o.s0 - 0.42f : o.s1 - 0.12f, b_end = side == 0 ? o.s0 + 0.12f : o.s1 + 0.42f;
    std::vector<Vec2> folds;
    for (float s = a; s <= b_end + 1e-4f; s += 0.02f)
      folds.emplace_back(s, curtain_y + 0.03f * std::sin(2.f * kPi * (s - a) / 0.13f));
    b.add_swept_slab(folds, 0.012f, 0.04f, rod_t - 0.03f, m(MK::kUpholsteryOchre));
  }
}

void add_door(SceneBuilder& b, MaterialLibrary& m, const WallOpening& o) {
  const float d = 0.05f;
  const int trim = m(MK::kTrimPaint);
  b.add_inward_box(Vec3(o.s0, 0.f, o.t0), Vec3(o.s1, d, o.t1), trim, kFaceMinX | kFaceMaxX | kFaceMinZ | kFaceMaxZ);
  b.add_fitted_quad(Vec3(o.s0, d, o.t0), Vec3(o.s1, d, o.t0), Vec3(o.s1, d, o.t1), Vec3(o.s0, d, o.t1),
                    m(MK::kDoorLeaf));
  // Architrave.
  b.add_box(Vec3(o.s0 - 0.08f, -0.02f, 0.f), Vec3(o.s0, 0.f, o.t1 + 0.08f), trim, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(o.s1, -0.02f, 0.f), Vec3(o.s1 + 0.08f, 0.f, o.t1 + 0.08f), trim, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(o.s0, -0.02f, o.t1), Vec3(o.s1, 0.f, o.t1 + 0.08f), trim, kAllFaces & ~kFaceMaxY);
  // Lever handle on a round rose, and a key plate below it.
  const float s = o.s1 - 0.09f, t = o.t0 + 1.0f;
  const int steel = m(MK::kBrushedSteel);
  b.add_rod(Vec3(s, d, t), Vec3(s, d - 0.012f, t), 0.03f, 24, steel);
  b.add_rod(Vec3(s, d - 0.012f, t), Vec3(s, -0.03f, t), 0.008f, 12, steel);
  b.add_rod(Vec3(s + 0.01f, -0.03f, t), Vec3(s - 0.12f, -0.03f, t), 0.01f, 12, steel);
  b.add_box(Vec3(s - 0.018f, d - 0.006f, t - 0.14f), Vec3(s + 0.018f, d, t - 0.06f), steel);
}

void add_skirting(SceneBuilder& b, MaterialLibrary& m, float s0, float s1) {
  b.add_box(Vec3(s0, -0.015f, 0.f), Vec3(s1, 0.f, 0.09f), m(MK::kTrimPaint), kAllFaces & ~kFaceMaxY & ~kFaceMinZ);
}

void add_picture(SceneBuilder& b, int picture_material, int frame_material, float s, float t, float width,
                 float height) {
  const float s0 = s - 0.5f * width, s1 = s + 0.5f * width, t0 = t - 0.5f * height, t1 = t + 0.5f * height;
  const float fw = 0.035f, depth = 0.03f;
  b.add_box(Vec3(s0 - fw, -depth, t0 - fw), Vec3(s0, 0.f, t1 + fw), frame_material, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(s1, -depth, t0 - fw), Vec3(s1 + fw, 0.f, t1 + fw), frame_material, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(s0, -depth, t0 - fw), Vec3(s1, 0.f, t0), frame_material, kAllFaces & ~kFaceMaxY);
  b.add_box(Vec3(s0, -depth, t1), Vec3(s1, 0.f, t1 + fw), frame_material, kAllFaces & ~kFaceMaxY);
  // The print sits a little behind the frame's front, on the backing.
  const float y = -0.012f;
  b.add_fitted_quad(Vec3(s0, y, t0), Vec3(s1, y, t0), Vec3(s1, y, t1), Vec3(s0, y, t1), picture_material);
}

void add_whiteboard(SceneBuilder& b, MaterialLibrary& m, float s, float t, float width, float height) {
  add_picture(b, m(MK::kWhiteboard), m(MK::kBrushedSteel), s, t, width, height);
  // Marker tray.
  const float t0 = t - 0.5f * height - 0.035f;
  b.add_box(Vec3(s - 0.3f * width, -0.09f, t0 - 0.02f), Vec3(s + 0.3f * width, 0.f, t0), m(MK::kBrushedSteel),
            kAllFaces & ~kFaceMaxY);
  const int plastic = m(MK::kDarkPlastic);
  for (int k = 0; k < 3; ++k) {
    const float x = s - 0.1f + 0.08f * k;
    b.add_rod(Vec3(x, -0.05f, t0 + 0.012f), Vec3(x + 0.12f, -0.05f, t0 + 0.012f), 0.01f, 10, plastic);
  }
}

// ------------------------------------------------------------------------------------------------
// Furniture (footprint-centred, front towards -y).

void add_sofa(SceneBuilder& b, MaterialLibrary& m, float length, int frame_fabric, int cushion_fabric) {
  const float hl = 0.5f * length, hd = 0.45f;
  for (float sx : {-1.f, 1.f})
    for (float sy : {-1.f, 1.f})
      b.add_frustum(Vec3(sx * (hl - 0.07f), sy * (hd - 0.07f), 0.f), 0.025f, 0.018f, 0.08f, 16, m(MK::kWalnutWood));
  b.add_box(Vec3(-hl, -hd, 0.08f), Vec3(hl, hd, 0.3f), frame_fabric);
  // Arms with round tops, extruded front to back.
  for (float side : {-1.f, 1.f}) {
    b.push(place(Vec3(side * (hl - 0.1f), 0.f, 0.f), kHalfPi));
    b.add_prism(rounded_top_profile(0.1f, 0.08f, 0.55f), -hd, hd, frame_fabric);
    b.pop();
  }
  // Backrest leaning back by about 11 degrees.
  b.push(tilt_x(Vec3(0.f, 0.24f, 0.3f), -0.2f));
  b.add_box(Vec3(-hl + 0.2f, -0.09f, 0.f), Vec3(hl - 0.2f, 0.09f, 0.52f), frame_fabric);
  b.pop();
  const int cushions = length > 1.7f ? 3 : 2;
  const float inner0 = -hl + 0.2f, width = (2.f * hl - 0.4f) / static_cast<float>(cushions);
  for (int k = 0; k < cushions; ++k) {
    const float x0 = inner0 + k * width + 0.005f, x1 = inner0 + (k + 1) * width - 0.005f;
    b.add_box(Vec3(x0, -hd + 0.02f, 0.3f), Vec3(x1, 0.16f, 0.45f), cushion_fabric);
    b.push(tilt_x(Vec3(0.f, 0.1f, 0.45f), -0.2f));
    b.add_box(Vec3(x0, -0.07f, 0.f), Vec3(x1, 0.07f, 0.36f), cushion_fabric);
    b.pop();
  }
}

void add_armchair(SceneBuilder& b, MaterialLibrary& m, int fabric) {
  for (float sx : {-1.f, 1.f})
    for (float sy : {-1.f, 1.f})
      b.add_frustum(Vec3(sx * 0.33f, sy * 0.33f, 0.f), 0.022f, 0.016f, 0.1f, 16, m(MK::kWalnutWood));
  b.add_box(Vec3(-0.4f, -0.4f, 0.1f), Vec3(0.4f, 0.4f, 0.38f), fabric);
  b.add_box(Vec3(-0.27f, -0.38f, 0.38f), Vec3(0.27f, 0.25f, 0.48f), fabric);
  for (float side : {-1.f, 1.f}) {
    b.push(place(Vec3(side * 0.33f, 0.f, 0.f), kHalfPi));
    b.add_prism(rounded_top_profile(0.07f, 0.1f, 0.58f), -0.4f, 0.4f, fabric);
    b.pop();
  }
  // Curved back: a thick slab bent round the seat.
  b.add_swept_slab(arc_path(Vec2(0.f, -0.1f), 0.42f, 0.52f, kPi - 0.52f, 16), 0.14f, 0.1f, 0.95f, fabric);
}

void add_round_table(SceneBuilder& b, MaterialLibrary& m, float radius, float height, int top_material) {
  b.add_cylinder(Vec3(0.f, 0.f, height - 0.035f), radius, 0.035f, 96, top_material);
  b.add_cylinder(Vec3(0.f, 0.f, height - 0.095f), 0.8f * radius, 0.06f, 48, top_material);
  for (int k = 0; k < 4; ++k) {
    const float a = kHalfPi * k + 0.25f * kPi;
    // Splayed legs end just above the floor on a small foot, so that nothing pokes through it.
    const Vec2 foot(0.75f * radius * std::cos(a), 0.75f * radius * std::sin(a));
    b.add_rod(Vec3(0.6f * radius * std::cos(a), 0.6f * radius * std::sin(a), height - 0.09f),
              Vec3(foot.x(), foot.y(), 0.012f), 0.022f, 16, top_material);
    b.add_cylinder(Vec3(foot.x(), foot.y(), 0.f), 0.026f, 0.014f, 16, top_material);
  }
  b.add_cylinder(Vec3(0.f, 0.f, 0.14f), 0.68f * radius, 0.02f, 48, top_material);
}

void add_table(SceneBuilder& b, MaterialLibrary& m, float width, float depth, float height, int top_material,
               int leg_material, bool round_legs) {
  const float hw = 0.5f * width, hd = 0.5f * depth;
  b.add_box(Vec3(-hw, -hd, height - 0.03f), Vec3(hw, hd, height), top_material);
  for (float sx : {-1.f, 1.f})
    for (float sy : {-1.f, 1.f}) {
      const float x = sx * (hw - 0.05f), y = sy * (hd - 0.05f);
      if (round_legs)
        b.add_cylinder(Vec3(x, y, 0.f), 0.02f, height - 0.03f, 16, leg_material);
      else
        b.add_box(Vec3(x - 0.02f, y - 0.02f, 0.f), Vec3(x + 0.02f, y + 0.02f, height - 0.03f), leg_material);
    }
  // Rails under the top, front and back.
  for (float sy : {-1.f, 1.f})
    b.add_box(Vec3(-hw + 0.07f, sy * (hd - 0.05f) - 0.01f, height - 0.1f),
              Vec3(hw - 0.07f, sy * (hd - 0.05f) + 0.01f, height - 0.03f), leg_material);
}

void add_dining_chair(SceneBuilder& b, MaterialLibrary& m, int seat_fabric) {
  const int wood = m(MK::kOakWood);
  for (float sx : {-1.f, 1.f}) {
    for (float sy : {-1.f, 1.f})
      b.add_box(Vec3(sx * 0.19f - 0.018f, sy * 0.19f - 0.018f, 0.f),
                Vec3(sx * 0.19f + 0.018f, sy * 0.19f + 0.018f, 0.44f), wood);
    // Back posts, leaning back slightly, and a side stretcher.
    b.add_rod(Vec3(sx * 0.19f, 0.19f, 0.44f), Vec3(sx * 0.19f, 0.245f, 0.92f), 0.016f, 12, wood);
    b.add_rod(Vec3(sx * 0.19f, -0.19f, 0.15f), Vec3(sx * 0.19f, 0.19f, 0.15f), 0.011f, 10, wood);
  }
  b.add_box(Vec3(-0.22f, -0.22f, 0.42f), Vec3(0.22f, 0.22f, 0.46f), wood);
  b.add_box(Vec3(-0.2f, -0.2f, 0.46f), Vec3(0.2f, 0.2f, 0.49f), seat_fabric);
  b.add_swept_slab(arc_path(Vec2(0.f, -0.2f), 0.45f, 1.12f, kPi - 1.12f, 12), 0.025f, 0.66f, 0.9f, wood);
}

void add_office_chair(SceneBuilder& b, MaterialLibrary& m) {
  const int metal = m(MK::kDarkMetal), plastic = m(MK::kDarkPlastic);
  for (int k = 0; k < 5; ++k) {
    const float a = kHalfPi + 2.f * kPi * k / 5.f;
    const Vec3 tip(0.3f * std::cos(a), 0.3f * std::sin(a), 0.06f);
    b.add_rod(Vec3(0.f, 0.f, 0.09f), tip, 0.018f, 12, metal);
    b.add_cylinder(Vec3(tip.x(), tip.y(), 0.f), 0.025f, 0.05f, 16, plastic);
  }
  b.add_cylinder(Vec3(0.f, 0.f, 0.05f), 0.05f, 0.06f, 24, metal);
  b.add_cylinder(Vec3(0.f, 0.f, 0.11f), 0.025f, 0.33f, 16, metal);
  b.add_box(Vec3(-0.25f, -0.24f, 0.44f), Vec3(0.25f, 0.24f, 0.5f), plastic);
  b.add_box(Vec3(-0.24f, -0.23f, 0.5f), Vec3(0.24f, 0.23f, 0.56f), m(MK::kUpholsteryBlue));
  b.add_rod(Vec3(0.f, 0.2f, 0.47f), Vec3(0.f, 0.3f, 0.66f), 0.02f, 12, metal);
  b.add_swept_slab(arc_path(Vec2(0.f, -0.05f), 0.36f, 0.96f, kPi - 0.96f, 14), 0.035f, 0.6f, 1.05f, m(MK::kMeshFabric));
  for (float sx : {-1.f, 1.f}) {
    b.add_rod(Vec3(sx * 0.25f, 0.f, 0.5f), Vec3(sx * 0.25f, 0.f, 0.68f), 0.012f, 10, metal);
    b.add_box(Vec3(sx * 0.25f - 0.03f, -0.13f, 0.68f), Vec3(sx * 0.25f + 0.03f, 0.1f, 0.705f), plastic);
  }
}

void add_vase(SceneBuilder& b, int material, float height, float radius) {
  static const float kProfile[][2] = {{0.55f, 0.f},   {0.85f, 0.12f}, {1.f, 0.35f}, {0.75f, 0.65f},
                                      {0.45f, 0.85f}, {0.5f, 0.95f},  {0.58f, 1.f}};
  std::vector<Vec2> profile;
  for (const auto& p : kProfile) profile.emplace_back(p[0] * radius, p[1] * height);
  b.add_lathe(Vec3::Zero(), profile, 48, material);
}

void add_bookshelf(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, float width, float height, int shelves,
                   int wood) {
  const float hw = 0.5f * width, hd = 0.16f, panel = 0.02f, plinth = 0.08f;
  b.add_box(Vec3(-hw, -hd, 0.f), Vec3(-hw + panel, hd, height), wood);
  b.add_box(Vec3(hw - panel, -hd, 0.f), Vec3(hw, hd, height), wood);
  b.add_box(Vec3(-hw + panel, -hd, height - panel), Vec3(hw - panel, hd, height), wood);
  b.add_box(Vec3(-hw + panel, hd - 0.012f, plinth), Vec3(hw - panel, hd, height - panel), wood);
  b.add_box(Vec3(-hw + panel, -hd, 0.f), Vec3(hw - panel, hd - 0.012f, plinth), wood);
  const float pitch = (height - plinth - panel) / static_cast<float>(shelves);
  const float x_begin = -hw + panel + 0.005f, x_end = hw - panel - 0.005f;
  for (int level = 0; level < shelves; ++level) {
    const float z0 = plinth + level * pitch + (level > 0 ? panel : 0.f);
    if (level > 0) b.add_box(Vec3(-hw + panel, -hd, z0 - panel), Vec3(hw - panel, hd - 0.012f, z0), wood);
    const float clear = plinth + (level + 1) * pitch - z0 - 0.025f;  // free height in this compartment
    float x = x_begin;
    while (x < x_end - 0.02f) {
      const float roll = draw(rng, 0.f, 1.f);
      if (roll < 0.07f) {  // a gap
        x += draw(rng, 0.03f, 0.08f);
      } else if (roll < 0.13f && x_end - x > 0.14f) {  // a vase
        const float r = draw(rng, 0.035f, 0.06f), h = std::min(clear - 0.02f, draw(rng, 0.12f, 0.28f));
        b.push(place(Vec3(x + r + 0.01f, 0.f, z0)));
        add_vase(b, rng.uniform() < 0.5 ? m(MK::kTerracotta) : m(MK::kCeramicTiles), h, r);
        b.pop();
        x += 2.f * r + 0.03f;
      } else if (roll < 0.17f && x_end - x > 0.3f) {  // a stack lying flat
        const float length = draw(rng, 0.2f, 0.26f);
        float z = z0;
        const int count = rng.uniform_int(3, 5);
        for (int k = 0; k < count && z < z0 + clear - 0.05f; ++k) {
          const float t = draw(rng, 0.02f, 0.045f);
          add_lying_book(b, m, x + draw(rng, 0.f, 0.02f), length, -hd + draw(rng, 0.005f, 0.03f),
                         draw(rng, 0.15f, 0.2f), z, t, rng.uniform_int(0, 15));
          z += t;
        }
        x += length + 0.04f;
      } else if (roll < 0.21f && x_end - x > 0.2f) {  // a book leaning on its bottom-right edge
        const float t = draw(rng, 0.02f, 0.04f), angle = draw(rng, 0.15f, 0.35f);
        const float h = std::min(draw(rng, 0.18f, 0.28f), (clear - 0.01f - t * std::sin(angle)) / std::cos(angle));
        const float pivot = x + t * std::cos(angle);
        b.push(tilt_y(Vec3(pivot, 0.f, z0), angle));
        add_book(b, m, -t, t, -hd + 0.01f, draw(rng, 0.15f, 0.22f), 0.f, h, rng.uniform_int(0, 15));
        b.pop();
        x = pivot + h * std::sin(angle) + 0.003f;
      } else {  // an upright book
        const float t = std::min(draw(rng, 0.018f, 0.05f), x_end - x);
        const float h = std::min(clear, draw(rng, 0.16f, 0.3f));
        add_book(b, m, x, t, -hd + draw(rng, 0.005f, 0.03f), draw(rng, 0.14f, 0.24f), z0, h, rng.uniform_int(0, 15));
        x += t + 0.002f;
      }
    }
  }
}

void add_chest_of_drawers(SceneBuilder& b, MaterialLibrary& m, float width, float depth, float height, int drawers,
                          int body_material) {
  const float hw = 0.5f * width, hd = 0.5f * depth;
  const int steel = m(MK::kBrushedSteel);
  b.add_box(Vec3(-hw + 0.03f, -hd + 0.03f, 0.f), Vec3(hw - 0.03f, hd - 0.03f, 0.06f), m(MK::kDarkMetal));
  b.add_box(Vec3(-hw, -hd, 0.06f), Vec3(hw, hd, height), body_material);
  b.add_box(Vec3(-hw - 0.01f, -hd - 0.01f, height), Vec3(hw + 0.01f, hd + 0.01f, height + 0.02f), body_material);
  const float pitch = (height - 0.1f) / static_cast<float>(drawers);
  for (int k = 0; k < drawers; ++k) {
    const float z0 = 0.08f + k * pitch + 0.008f, z1 = 0.08f + (k + 1) * pitch - 0.008f, zc = z0 + 0.65f * (z1 - z0);
    b.add_box(Vec3(-hw + 0.02f, -hd - 0.015f, z0), Vec3(hw - 0.02f, -hd, z1), body_material);
    const float half = std::min(0.09f, 0.25f * width);
    b.add_rod(Vec3(-half, -hd - 0.045f, zc), Vec3(half, -hd - 0.045f, zc), 0.008f, 10, steel);
    for (float x : {-half + 0.01f, half - 0.01f})
      b.add_rod(Vec3(x, -hd - 0.015f, zc), Vec3(x, -hd - 0.045f, zc), 0.006f, 8, steel);
  }
}

void add_floor_lamp(SceneBuilder& b, MaterialLibrary& m) {
  b.add_cylinder(Vec3::Zero(), 0.15f, 0.025f, 64, m(MK::kDarkMetal));
  b.add_cylinder(Vec3(0.f, 0.f, 0.025f), 0.012f, 1.37f, 12, m(MK::kBrushedSteel));
  b.add_frustum(Vec3(0.f, 0.f, 1.38f), 0.22f, 0.14f, 0.28f, 64, m(MK::kLampshade));
}

void add_table_lamp(SceneBuilder& b, MaterialLibrary& m) {
  b.add_lathe(Vec3::Zero(),
              {Vec2(0.07f, 0.f), Vec2(0.09f, 0.05f), Vec2(0.1f, 0.12f), Vec2(0.07f, 0.2f), Vec2(0.03f, 0.25f),
               Vec2(0.03f, 0.28f)},
              48, m(MK::kCeramicTiles));
  b.add_cylinder(Vec3(0.f, 0.f, 0.28f), 0.008f, 0.06f, 10, m(MK::kBrushedSteel));
  b.add_frustum(Vec3(0.f, 0.f, 0.32f), 0.17f, 0.1f, 0.2f, 64, m(MK::kLampshade));
}

void add_plant(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, float size, float max_reach) {
  const float s = size;
  b.add_lathe(Vec3::Zero(),
              {Vec2(0.10f * s, 0.f), Vec2(0.14f * s, 0.26f * s), Vec2(0.16f * s, 0.26f * s), Vec2(0.16f * s, 0.3f * s)},
              64, m(MK::kTerracotta));
  b.add_cylinder(Vec3(0.f, 0.f, 0.3f * s), 0.145f * s, 0.006f, 64, m(MK::kSoil));
  const int leaf = m(MK::kLeaf);
  const int stems = rng.uniform_int(6, 8);
  for (int k = 0; k < stems; ++k) {
    const float heading = 2.f * kPi * k / stems + draw(rng, -0.3f, 0.3f);
    const float length = draw(rng, 0.45f, 0.95f) * s, tip_leaf = draw(rng, 0.18f, 0.28f) * s;
    // Lean no further than keeps every leaf within max_reach of the pot's axis (walls nearby).
    const float lean_limit = std::asin(std::clamp((max_reach - 0.03f * s - 0.28f * s) / length, 0.05f, 0.48f));
    const float lean = draw(rng, 0.15f, 0.5f) * lean_limit / 0.5f;
    const Vec3 base(0.03f * s * std::cos(heading), 0.03f * s * std::sin(heading), 0.3f * s);
    const Vec3 tip =
        base + length * Vec3(std::sin(lean) * std::cos(heading), std::sin(lean) * std::sin(heading), std::cos(lean));
    b.add_rod(base, tip, 0.007f * s, 8, leaf);
    add_leaf(b, leaf, tip, heading + draw(rng, -0.4f, 0.4f), draw(rng, 0.2f, 0.6f), tip_leaf,
             draw(rng, 0.06f, 0.09f) * s);
    for (float t : {0.3f, 0.5f, 0.7f, 0.85f}) {
      const Vec3 at = base + t * (tip - base);
      add_leaf(b, leaf, at, heading + draw(rng, -1.2f, 1.2f), draw(rng, 0.3f, 0.8f), draw(rng, 0.14f, 0.22f) * s,
               draw(rng, 0.05f, 0.08f) * s);
    }
  }
}

void add_monitor(SceneBuilder& b, MaterialLibrary& m, int screen_variant) {
  const int plastic = m(MK::kDarkPlastic);
  b.add_box(Vec3(-0.11f, -0.06f, 0.f), Vec3(0.11f, 0.12f, 0.015f), plastic);
  b.add_box(Vec3(-0.025f, 0.05f, 0.015f), Vec3(0.025f, 0.07f, 0.3f), plastic);
  b.add_box(Vec3(-0.05f, 0.035f, 0.25f), Vec3(0.05f, 0.06f, 0.35f), plastic);
  b.add_box(Vec3(-0.28f, 0.f, 0.13f), Vec3(0.28f, 0.035f, 0.47f), plastic);
  b.add_fitted_quad(Vec3(-0.265f, -0.001f, 0.145f), Vec3(0.265f, -0.001f, 0.145f), Vec3(0.265f, -0.001f, 0.455f),
                    Vec3(-0.265f, -0.001f, 0.455f), m(MK::kScreen, screen_variant));
}

void add_dresser(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, int books) {
  add_chest_of_drawers(b, m, 0.8f, 0.45f, 0.85f, 4, m(MK::kOakWood));
  b.push(place(Vec3(-0.2f, 0.f, 0.87f), 0.2f));
  add_book_stack(b, m, rng, books);
  b.pop();
  b.push(place(Vec3(0.25f, 0.05f, 0.87f)));
  add_vase(b, m(MK::kTerracotta), 0.22f, 0.06f);
  b.pop();
}

void add_desk_with_screen(SceneBuilder& b, MaterialLibrary& m, int screen_variant) {
  add_table(b, m, 1.4f, 0.7f, 0.74f, m(MK::kDeskLaminate), m(MK::kDarkMetal), false);
  b.push(place(Vec3(0.f, 0.12f, 0.74f)));
  add_monitor(b, m, screen_variant);
  b.pop();
  b.push(place(Vec3(-0.05f, -0.16f, 0.74f)));
  add_keyboard_and_mouse(b, m);
  b.pop();
}

void add_keyboard_and_mouse(SceneBuilder& b, MaterialLibrary& m) {
  const int plastic = m(MK::kDarkPlastic);
  b.add_box(Vec3(-0.22f, -0.07f, 0.f), Vec3(0.22f, 0.07f, 0.022f), plastic, kAllFaces & ~kFaceMaxZ);
  b.add_fitted_quad(Vec3(-0.22f, -0.07f, 0.022f), Vec3(0.22f, -0.07f, 0.022f), Vec3(0.22f, 0.07f, 0.022f),
                    Vec3(-0.22f, 0.07f, 0.022f), m(MK::kKeyboard));
  b.add_box(Vec3(0.25f, -0.11f, 0.f), Vec3(0.43f, 0.11f, 0.003f), m(MK::kUpholsteryBlue));
  b.push(place(Vec3(0.34f, 0.f, 0.003f), kHalfPi));
  b.add_prism(rounded_top_profile(0.03f, 0.f, 0.008f), -0.05f, 0.05f, plastic);
  b.pop();
}

void add_tv_unit(SceneBuilder& b, MaterialLibrary& m) {
  const int walnut = m(MK::kWalnutWood), oak = m(MK::kOakWood), steel = m(MK::kBrushedSteel),
            plastic = m(MK::kDarkPlastic);
  for (float sx : {-1.f, 1.f})
    for (float sy : {-1.f, 1.f}) b.add_frustum(Vec3(sx * 0.74f, sy * 0.17f, 0.f), 0.02f, 0.015f, 0.1f, 16, steel);
  b.add_box(Vec3(-0.8f, -0.22f, 0.1f), Vec3(0.8f, 0.22f, 0.52f), walnut);
  for (int k = 0; k < 3; ++k) {
    const float x0 = -0.79f + k * 0.527f + 0.01f, x1 = x0 + 0.507f;
    b.add_box(Vec3(x0, -0.235f, 0.13f), Vec3(x1, -0.22f, 0.49f), oak);
    const float xh = k == 2 ? x0 + 0.04f : x1 - 0.04f;
    b.add_rod(Vec3(xh, -0.255f, 0.25f), Vec3(xh, -0.255f, 0.37f), 0.007f, 10, steel);
  }
  // Television on a pedestal stand.
  b.add_box(Vec3(-0.2f, -0.1f, 0.52f), Vec3(0.2f, 0.1f, 0.535f), plastic);
  b.add_box(Vec3(-0.04f, 0.01f, 0.535f), Vec3(0.04f, 0.04f, 0.66f), plastic);
  b.add_box(Vec3(-0.62f, 0.f, 0.6f), Vec3(0.62f, 0.05f, 1.32f), plastic);
  b.add_fitted_quad(Vec3(-0.6f, -0.001f, 0.62f), Vec3(0.6f, -0.001f, 0.62f), Vec3(0.6f, -0.001f, 1.3f),
                    Vec3(-0.6f, -0.001f, 1.3f), m(MK::kTvPicture));
  b.push(place(Vec3(0.72f, 0.f, 0.52f)));
  add_vase(b, m(MK::kTerracotta), 0.24f, 0.05f);
  b.pop();
}

void add_rug(SceneBuilder& b, MaterialLibrary& m, float width, float depth) {
  const float hw = 0.5f * width, hd = 0.5f * depth, h = 0.008f;
  const int rug = m(MK::kRug);
  b.add_box(Vec3(-hw, -hd, 0.f), Vec3(hw, hd, h), rug, kFaceMinX | kFaceMaxX | kFaceMinY | kFaceMaxY);
  b.add_fitted_quad(Vec3(-hw, -hd, h), Vec3(hw, -hd, h), Vec3(hw, hd, h), Vec3(-hw, hd, h), rug);
}

void add_radiator(SceneBuilder& b, MaterialLibrary& m, float width) {
  const int paint = m(MK::kTrimPaint), steel = m(MK::kBrushedSteel);
  const float hw = 0.5f * width;
  b.add_box(Vec3(-hw, -0.045f, 0.15f), Vec3(hw, -0.025f, 0.7f), paint);
  for (float x = -hw; x + 0.03f <= hw + 1e-4f; x += 0.055f)
    b.add_box(Vec3(x, -0.1f, 0.12f), Vec3(x + 0.03f, -0.045f, 0.72f), paint);
  for (float sx : {-1.f, 1.f}) {
    b.add_rod(Vec3(sx * (hw + 0.03f), -0.07f, 0.f), Vec3(sx * (hw + 0.03f), -0.07f, 0.2f), 0.012f, 12, steel);
    b.add_rod(Vec3(sx * (hw + 0.045f), -0.07f, 0.2f), Vec3(sx * (hw - 0.02f), -0.07f, 0.2f), 0.014f, 12, steel);
  }
}

void add_bin(SceneBuilder& b, MaterialLibrary& m) {
  b.add_lathe(Vec3::Zero(), {Vec2(0.11f, 0.f), Vec2(0.14f, 0.34f), Vec2(0.15f, 0.34f), Vec2(0.15f, 0.36f)}, 64,
              m(MK::kBrushedSteel));
}

void add_book_stack(SceneBuilder& b, MaterialLibrary& m, RandomStream& rng, int count) {
  float z = 0.f;
  for (int k = 0; k < count; ++k) {
    const float length = draw(rng, 0.2f, 0.28f), depth = draw(rng, 0.15f, 0.2f), t = draw(rng, 0.02f, 0.045f);
    b.push(place(Vec3(0.f, 0.f, z), draw(rng, -0.25f, 0.25f)));
    add_lying_book(b, m, -0.5f * length, length, -0.5f * depth, depth, 0.f, t, rng.uniform_int(0, 15));
    b.pop();
    z += t;
  }
}

void add_pouf(SceneBuilder& b, int fabric) {
  // A round seat cushion: a barrel with rounded edges.
  std::vector<Vec2> profile;
  const int n = 8;
  for (int k = 0; k <= n; ++k) {
    const float a = -kHalfPi + kPi * static_cast<float>(k) / n;
    profile.emplace_back(0.24f + 0.06f * std::cos(a), 0.2f + 0.2f * std::sin(a));
  }
  profile.front().x() = 0.2f;
  profile.back().x() = 0.2f;
  b.add_lathe(Vec3::Zero(), profile, 64, fabric);
}

void add_coat_stand(SceneBuilder& b, MaterialLibrary& m) {
  const int walnut = m(MK::kWalnutWood), steel = m(MK::kBrushedSteel);
  b.add_cylinder(Vec3::Zero(), 0.2f, 0.03f, 40, m(MK::kDarkMetal));
  b.add_cylinder(Vec3(0.f, 0.f, 0.03f), 0.018f, 1.72f, 16, walnut);
  b.add_lathe(Vec3(0.f, 0.f, 1.75f), {Vec2(0.02f, 0.f), Vec2(0.035f, 0.03f), Vec2(0.02f, 0.06f), Vec2(0.f, 0.07f)}, 20,
              walnut);
  for (int k = 0; k < 4; ++k) {
    const float a = kHalfPi * k;
    b.add_rod(Vec3(0.f, 0.f, 1.55f), Vec3(0.14f * std::cos(a), 0.14f * std::sin(a), 1.68f), 0.008f, 8, steel);
  }
}

void add_printer(SceneBuilder& b, MaterialLibrary& m) {
  const int plastic = m(MK::kDarkPlastic);
  b.add_box(Vec3(-0.22f, -0.2f, 0.f), Vec3(0.22f, 0.2f, 0.22f), plastic);
  b.add_box(Vec3(-0.15f, -0.32f, 0.05f), Vec3(0.15f, -0.2f, 0.065f), plastic);
  b.add_box(Vec3(-0.14f, -0.3f, 0.065f), Vec3(0.14f, -0.2f, 0.08f), m(MK::kPaperEdges));
  b.add_box(Vec3(-0.2f, 0.f, 0.22f), Vec3(0.2f, 0.18f, 0.26f), m(MK::kBrushedSteel));
}

void add_pendant_lamp(SceneBuilder& b, MaterialLibrary& m, float x, float y, float ceiling_height) {
  const int metal = m(MK::kDarkMetal);
  b.add_cylinder(Vec3(x, y, ceiling_height - 0.03f), 0.07f, 0.03f, 24, metal);
  b.add_cylinder(Vec3(x, y, ceiling_height - 0.43f), 0.004f, 0.4f, 8, metal);
  b.add_frustum(Vec3(x, y, ceiling_height - 0.62f), 0.2f, 0.07f, 0.19f, 64, m(MK::kLampshade));
}

void add_ceiling_panel_light(SceneBuilder& b, MaterialLibrary& m, float x, float y, float ceiling_height) {
  b.add_box(Vec3(x - 0.3f, y - 0.3f, ceiling_height - 0.03f), Vec3(x + 0.3f, y + 0.3f, ceiling_height),
            m(MK::kBrushedSteel), kAllFaces & ~kFaceMaxZ);
}

}  // namespace panoscan::scenes
