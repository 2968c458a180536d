#include "procedural_textures.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "texture_canvas.h"

namespace panoscan::scenes {

namespace {

constexpr float kPi = 3.14159265358979323846f;

}  // namespace

Texture parquet_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.5f, 0.35f, 0.2f));
  const int cell = size / 8, plank = cell / 4;
  const Colour light(0.80f, 0.62f, 0.40f), dark(0.42f, 0.26f, 0.13f);
  const float inv = 1.f / canvas.sizef();
  const Fbm along_x(8, 32, 3, seed + 11), along_y(32, 8, 3, seed + 11);
  for (int cy = 0; cy < size / cell; ++cy)
    for (int cx = 0; cx < size / cell; ++cx) {
      const bool horizontal = (cx + cy) % 2 == 0;
      for (int k = 0; k < 4; ++k) {
        const Colour base = light + (dark - light) * dice.uniform(0.f, 1.f);
        const float brightness = dice.uniform(0.75f, 1.15f), phase = dice.uniform(0.f, 100.f);
        const int x0 = cx * cell + (horizontal ? 0 : k * plank), y0 = cy * cell + (horizontal ? k * plank : 0);
        const int w = horizontal ? cell : plank, h = horizontal ? plank : cell;
        for (int y = y0; y < y0 + h; ++y)
          for (int x = x0; x < x0 + w; ++x) {
            // Grain runs along the plank: growth rings are stripes across it, warped by noise.
            const float along = horizontal ? x : y, across = horizontal ? y : x;
            const float warp = 7.f * (horizontal ? along_x : along_y)((x + 0.5f) * inv, (y + 0.5f) * inv);
            const float ring = std::fmod(across * 0.45f + warp + phase + 0.02f * along, 5.5f) / 5.5f;
            const float grain = ring < 0.22f ? 0.72f : 1.f;
            canvas.at(x, y) = base * brightness * grain;
          }
        // A knot now and then: dark heart with a lighter ring.
        if (dice.chance(0.25f)) {
          const float kx = x0 + dice.uniform(0.2f, 0.8f) * w, ky = y0 + dice.uniform(0.3f, 0.7f) * h;
          const float r = dice.uniform(3.f, 6.f);
          canvas.ellipse(kx, ky, horizontal ? 2.f * r : r, horizontal ? r : 2.f * r, 0.f, base * 0.55f);
          canvas.ellipse(kx, ky, horizontal ? r : 0.5f * r, horizontal ? 0.5f * r : r, 0.f, Colour(0.2f, 0.1f, 0.05f));
        }
        // The joint between planks.
        if (horizontal)
          canvas.rect(x0, y0, x0 + w, y0 + 2, Colour(0.12f, 0.08f, 0.05f));
        else
          canvas.rect(x0, y0, x0 + 2, y0 + h, Colour(0.12f, 0.08f, 0.05f));
      }
      canvas.frame(cx * cell, cy * cell, (cx + 1) * cell, (cy + 1) * cell, 2.f, Colour(0.1f, 0.07f, 0.04f));
    }
  canvas.modulate(8, 3, 0.06f, seed + 3);
  return canvas.to_texture(name);
}

Texture damask_wallpaper_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.93f, 0.88f, 0.76f));
  const std::vector<Colour> inks = {Colour(0.50f, 0.08f, 0.12f), Colour(0.05f, 0.30f, 0.32f),
                                    Colour(0.10f, 0.12f, 0.36f), Colour(0.35f, 0.38f, 0.10f)};
  const Colour gold(0.78f, 0.62f, 0.25f);
  const float pitch = canvas.sizef() / 8.f;
  // Pin stripes behind the motifs.
  for (int i = 0; i < 16; ++i) canvas.rect(i * pitch * 0.5f, 0.f, i * pitch * 0.5f + 3.f, canvas.sizef(), gold);
  for (int row = 0; row < 8; ++row)
    for (int column = 0; column < 8; ++column) {
      const float cx = (column + 0.5f + 0.5f * (row % 2)) * pitch, cy = (row + 0.5f) * pitch;
      const Colour ink = dice.pick(inks);
      const float turn = dice.uniform(0.f, 2.f * kPi);
      const int petals = dice.integer(5, 8);
      canvas.ring(cx, cy, pitch * 0.34f, pitch * 0.37f, ink);
      for (int p = 0; p < petals; ++p) {
        const float a = turn + 2.f * kPi * p / petals;
        canvas.ellipse(cx + std::cos(a) * pitch * 0.19f, cy + std::sin(a) * pitch * 0.19f, pitch * 0.14f,
                       pitch * 0.055f, a, ink);
      }
      canvas.disc(cx, cy, pitch * 0.08f, gold);
      canvas.disc(cx, cy, pitch * 0.035f, ink);
      // A small diamond between neighbouring motifs.
      const float dx = cx + 0.5f * pitch, dy = cy, r = pitch * 0.09f;
      canvas.polygon({Point(dx - r, dy), Point(dx, dy - 1.6f * r), Point(dx + r, dy), Point(dx, dy + 1.6f * r)},
                     dice.pick(inks));
    }
  canvas.modulate(16, 3, 0.05f, seed + 5);
  return canvas.to_texture(name);
}

Texture striped_wallpaper_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.88f, 0.85f, 0.74f));
  const std::vector<Colour> stripes = {Colour(0.88f, 0.85f, 0.74f), Colour(0.45f, 0.56f, 0.46f),
                                       Colour(0.20f, 0.32f, 0.26f), Colour(0.80f, 0.70f, 0.52f)};
  float x = 0.f;
  int index = 0;
  while (x < canvas.sizef()) {
    const float width = std::min(dice.uniform(12.f, 56.f), canvas.sizef() - x);
    canvas.rect(x, 0.f, x + width, canvas.sizef(), stripes[static_cast<std::size_t>(index % 4)]);
    canvas.rect(x, 0.f, x + 2.f, canvas.sizef(), Colour(0.55f, 0.15f, 0.12f));
    x += width;
    ++index;
  }
  const std::vector<Colour> leaf_colours = {Colour(0.10f, 0.25f, 0.12f), Colour(0.75f, 0.55f, 0.15f),
                                            Colour(0.95f, 0.93f, 0.85f), Colour(0.45f, 0.12f, 0.10f)};
  const int sprigs = size * size / 4500;
  for (int i = 0; i < sprigs; ++i) {
    const float sx = dice.uniform(0.f, canvas.sizef()), sy = dice.uniform(0.f, canvas.sizef());
    const float angle = dice.uniform(0.f, 2.f * kPi), length = dice.uniform(20.f, 42.f);
    const Colour colour = dice.pick(leaf_colours);
    const float ex = sx + std::cos(angle) * length, ey = sy + std::sin(angle) * length;
    canvas.line(sx, sy, ex, ey, 2.5f, colour);
    const int leaves = dice.integer(2, 4);
    for (int k = 1; k <= leaves; ++k) {
      const float t = static_cast<float>(k) / (leaves + 1);
      for (int side = -1; side <= 1; side += 2) {
        const float a = angle + side * 0.7f;
        const float lx = sx + (ex - sx) * t + std::cos(a) * 7.f, ly = sy + (ey - sy) * t + std::sin(a) * 7.f;
        canvas.ellipse(lx, ly, 8.f, 3.5f, a, colour);
      }
    }
    canvas.disc(ex, ey, 4.f, Colour(0.7f, 0.1f, 0.12f));
  }
  canvas.modulate(16, 3, 0.05f, seed + 9);
  return canvas.to_texture(name);
}

Texture geometric_wallpaper_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.9f, 0.9f, 0.88f));
  const std::vector<Colour> palette = {Colour(0.95f, 0.93f, 0.88f), Colour(0.15f, 0.18f, 0.25f),
                                       Colour(0.85f, 0.55f, 0.20f), Colour(0.30f, 0.55f, 0.60f),
                                       Colour(0.70f, 0.25f, 0.25f), Colour(0.62f, 0.66f, 0.58f)};
  const int cells = 16;
  const float cell = canvas.sizef() / cells;
  for (int cy = 0; cy < cells; ++cy)
    for (int cx = 0; cx < cells; ++cx) {
      const float x0 = cx * cell, y0 = cy * cell, x1 = x0 + cell, y1 = y0 + cell;
      if (dice.chance(0.5f)) {
        canvas.polygon({Point(x0, y0), Point(x1, y0), Point(x0, y1)}, dice.pick(palette));
        canvas.polygon({Point(x1, y0), Point(x1, y1), Point(x0, y1)}, dice.pick(palette));
      } else {
        canvas.polygon({Point(x0, y0), Point(x1, y0), Point(x1, y1)}, dice.pick(palette));
        canvas.polygon({Point(x0, y0), Point(x1, y1), Point(x0, y1)}, dice.pick(palette));
      }
      if (dice.chance(0.2f)) canvas.disc(x0 + 0.5f * cell, y0 + 0.5f * cell, 0.12f * cell, dice.pick(palette));
    }
  canvas.modulate(16, 3, 0.05f, seed + 13);
  return canvas.to_texture(name);
}

Texture brick_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  const Colour mortar(0.80f, 0.78f, 0.72f);
  Canvas canvas(size, mortar);
  const std::vector<Colour> bricks = {Colour(0.45f, 0.18f, 0.12f), Colour(0.60f, 0.26f, 0.16f),
                                      Colour(0.70f, 0.42f, 0.24f), Colour(0.36f, 0.24f, 0.18f),
                                      Colour(0.50f, 0.47f, 0.45f), Colour(0.78f, 0.66f, 0.52f)};
  const int rows = 32, per_row = 8;
  const float height = canvas.sizef() / rows, length = canvas.sizef() / per_row, joint = 6.f;
  for (int row = 0; row < rows; ++row)
    for (int k = 0; k < per_row; ++k) {
      const float x0 = k * length + (row % 2) * 0.5f * length, y0 = row * height;
      const Colour colour = dice.jitter(dice.pick(bricks), 0.15f);
      canvas.rect(x0, y0, x0 + length - joint, y0 + height - joint, colour);
      // A darker fired end and a few chips.
      if (dice.chance(0.4f)) canvas.rect(x0, y0, x0 + 0.25f * length, y0 + height - joint, colour * 0.75f, 0.6f);
      const int chips = dice.integer(0, 3);
      for (int c = 0; c < chips; ++c)
        canvas.disc(x0 + dice.uniform(0.f, length - joint), y0 + dice.uniform(0.f, height - joint),
                    dice.uniform(1.5f, 4.f), colour * 0.45f);
    }
  canvas.modulate(32, 4, 0.10f, seed + 17);
  return canvas.to_texture(name);
}

Texture coffered_ceiling_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.9f, 0.88f, 0.84f));
  const int cells = 4;
  const float cell = canvas.sizef() / cells, s = cell / 256.f;
  const std::vector<Colour> tints = {Colour(0.93f, 0.90f, 0.82f), Colour(0.82f, 0.88f, 0.92f),
                                     Colour(0.85f, 0.90f, 0.80f), Colour(0.94f, 0.84f, 0.80f)};
  const Colour line_ink(0.30f, 0.24f, 0.20f), rosette_ink(0.55f, 0.42f, 0.22f);
  for (int cy = 0; cy < cells; ++cy)
    for (int cx = 0; cx < cells; ++cx) {
      const float x0 = cx * cell, y0 = cy * cell, x1 = x0 + cell, y1 = y0 + cell;
      const Colour base = dice.pick(tints);
      canvas.rect(x0, y0, x1, y1, base);
      // Bevelled beam: lit edge on two sides, shadowed on the other two.
      const float beam = 20.f * s;
      canvas.rect(x0, y0, x1, y0 + beam, Colour(0.98f, 0.97f, 0.95f));
      canvas.rect(x0, y0, x0 + beam, y1, Colour(0.98f, 0.97f, 0.95f));
      canvas.rect(x0 + beam, y1 - beam, x1, y1, Colour(0.52f, 0.50f, 0.48f));
      canvas.rect(x1 - beam, y0 + beam, x1, y1, Colour(0.52f, 0.50f, 0.48f));
      canvas.frame(x0 + 40.f * s, y0 + 40.f * s, x1 - 40.f * s, y1 - 40.f * s, 4.f * s, line_ink);
      // Corner blocks with a dot.
      for (int corner = 0; corner < 4; ++corner) {
        const float bx = (corner % 2) ? x1 - 64.f * s : x0 + 40.f * s,
                    by = (corner / 2) ? y1 - 64.f * s : y0 + 40.f * s;
        canvas.rect(bx, by, bx + 24.f * s, by + 24.f * s, rosette_ink);
        canvas.disc(bx + 12.f * s, by + 12.f * s, 5.f * s, base);
      }
      // Diamond outline and rosette in the middle.
      const float mx = x0 + 0.5f * cell, my = y0 + 0.5f * cell, r = 78.f * s;
      canvas.polygon({Point(mx - r, my), Point(mx, my - r), Point(mx + r, my), Point(mx, my + r)}, line_ink);
      const float ri = r - 6.f * s;
      canvas.polygon({Point(mx - ri, my), Point(mx, my - ri), Point(mx + ri, my), Point(mx, my + ri)}, base);
      const int petals = dice.integer(6, 9);
      const float turn = dice.uniform(0.f, kPi);
      for (int p = 0; p < petals; ++p) {
        const float a = turn + 2.f * kPi * p / petals;
        canvas.ellipse(mx + std::cos(a) * 30.f * s, my + std::sin(a) * 30.f * s, 24.f * s, 8.f * s, a, rosette_ink);
      }
      canvas.disc(mx, my, 12.f * s, line_ink);
      canvas.disc(mx, my, 5.f * s, Colour(0.95f, 0.9f, 0.7f));
    }
  // Water stains: low-frequency blotches.
  const float inv = 1.f / canvas.sizef();
  const Fbm stains(4, 4, 4, seed + 23);
  canvas.each([&](int x, int y, Colour& p) {
    const float n = stains((x + 0.5f) * inv, (y + 0.5f) * inv);
    if (n > 0.62f) p = p.cwiseProduct(Colour(0.86f, 0.80f, 0.70f));
  });
  canvas.modulate(32, 3, 0.04f, seed + 29);
  return canvas.to_texture(name);
}

Texture acoustic_ceiling_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.83f, 0.82f, 0.79f));
  const int tiles = 4;
  const float tile = canvas.sizef() / tiles, s = tile / 256.f;
  for (int ty = 0; ty < tiles; ++ty)
    for (int tx = 0; tx < tiles; ++tx) {
      const float x0 = tx * tile, y0 = ty * tile;
      const int fissures = static_cast<int>(260 * s * s);
      for (int i = 0; i < fissures; ++i) {
        const float cx = x0 + dice.uniform(0.f, tile), cy = y0 + dice.uniform(0.f, tile);
        const float a = dice.uniform(0.f, kPi), half = dice.uniform(3.f, 11.f) * s;
        const float grey = dice.uniform(0.28f, 0.5f);
        canvas.line(cx - std::cos(a) * half, cy - std::sin(a) * half, cx + std::cos(a) * half, cy + std::sin(a) * half,
                    dice.uniform(2.f, 3.5f) * s, Colour(grey, grey * 0.98f, grey * 0.95f));
      }
      const int pinholes = static_cast<int>(120 * s * s);
      for (int i = 0; i < pinholes; ++i)
        canvas.disc(x0 + dice.uniform(0.f, tile), y0 + dice.uniform(0.f, tile), 1.6f * s, Colour(0.35f, 0.35f, 0.35f));
      if (dice.chance(0.2f))
        canvas.ellipse(x0 + dice.uniform(0.3f, 0.7f) * tile, y0 + dice.uniform(0.3f, 0.7f) * tile,
                       dice.uniform(20.f, 45.f) * s, dice.uniform(15.f, 30.f) * s, dice.uniform(0.f, kPi),
                       Colour(0.62f, 0.52f, 0.38f), 0.5f);
      // T-bar grid with shadow lines.
      canvas.rect(x0, y0, x0 + tile, y0 + 10.f * s, Colour(0.95f, 0.95f, 0.94f));
      canvas.rect(x0, y0, x0 + 10.f * s, y0 + tile, Colour(0.95f, 0.95f, 0.94f));
      canvas.rect(x0, y0 + 10.f * s, x0 + tile, y0 + 12.f * s, Colour(0.40f, 0.40f, 0.40f));
      canvas.rect(x0 + 10.f * s, y0 + 10.f * s, x0 + 12.f * s, y0 + tile, Colour(0.40f, 0.40f, 0.40f));
    }
  canvas.modulate(16, 3, 0.05f, seed + 31);
  return canvas.to_texture(name);
}

Texture carpet_tiles_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.3f, 0.3f, 0.32f));
  const int tiles = 4;
  const float tile = canvas.sizef() / tiles, s = tile / 256.f;
  const std::vector<Colour> grounds = {Colour(0.24f, 0.28f, 0.36f), Colour(0.36f, 0.34f, 0.30f),
                                       Colour(0.28f, 0.33f, 0.30f)};
  const std::vector<Colour> flecks = {Colour(0.78f, 0.78f, 0.76f), Colour(0.68f, 0.32f, 0.16f),
                                      Colour(0.06f, 0.06f, 0.07f), Colour(0.85f, 0.75f, 0.35f)};
  for (int ty = 0; ty < tiles; ++ty)
    for (int tx = 0; tx < tiles; ++tx) {
      const float x0 = tx * tile, y0 = ty * tile;
      const Colour ground = dice.pick(grounds);
      canvas.rect(x0, y0, x0 + tile, y0 + tile, ground);
      const bool horizontal = (tx + ty) % 2 == 0;  // quarter-turned installation
      for (float t = 4.f * s; t < tile; t += 18.f * s) {
        if (horizontal)
          canvas.rect(x0, y0 + t, x0 + tile, y0 + t + 7.f * s, ground * 1.5f);
        else
          canvas.rect(x0 + t, y0, x0 + t + 7.f * s, y0 + tile, ground * 1.5f);
      }
      const int count = static_cast<int>(330 * s * s);
      for (int i = 0; i < count; ++i) {
        const float fx = x0 + dice.uniform(0.f, tile), fy = y0 + dice.uniform(0.f, tile);
        const float w = dice.uniform(3.f, 7.f) * s, h = dice.uniform(3.f, 7.f) * s;
        canvas.rect(fx, fy, fx + w, fy + h, dice.pick(flecks));
      }
      canvas.frame(x0, y0, x0 + tile, y0 + tile, 2.f * s, Colour(0.1f, 0.1f, 0.1f));
    }
  canvas.modulate(64, 2, 0.06f, seed + 37);
  return canvas.to_texture(name);
}

Texture wood_texture(const std::string& name, int size, std::uint64_t seed, const Colour& light, const Colour& dark) {
  Dice dice(seed);
  Canvas canvas(size, light);
  const float inv = 1.f / canvas.sizef();
  const Fbm grain_warp(4, 16, 3, seed + 41);
  // Boards across v, each with its own tone, grain phase, end joints and knots.
  float y = 0.f;
  while (y < canvas.sizef()) {
    const float board = std::min(dice.uniform(0.1f, 0.22f) * canvas.sizef(), canvas.sizef() - y);
    const Colour tone = light + (dark - light) * dice.uniform(0.f, 0.7f);
    const float phase = dice.uniform(0.f, 50.f);
    const int y0 = static_cast<int>(y), y1 = static_cast<int>(y + board);
    for (int py = y0; py < y1; ++py)
      for (int px = 0; px < canvas.size(); ++px) {
        const float warp = 9.f * grain_warp((px + 0.5f) * inv, (py + 0.5f) * inv);
        const float ring = std::fmod(py * 0.5f + warp + phase, 7.f) / 7.f;
        const float grain = ring < 0.3f ? 0.6f + ring : 1.f;
        canvas.at(px, py) = tone * grain;
      }
    const int knots = dice.integer(1, 4);
    for (int k = 0; k < knots; ++k) {
      const float kx = dice.uniform(0.f, canvas.sizef()), ky = y + dice.uniform(0.3f, 0.7f) * board;
      const float r = dice.uniform(3.f, 6.f);
      canvas.ellipse(kx, ky, 2.5f * r, r, 0.f, tone * 0.55f);
      canvas.ellipse(kx, ky, r, 0.45f * r, 0.f, dark * 0.35f);
    }
    canvas.rect(0.f, y, canvas.sizef(), y + 2.f, dark * 0.35f);
    const int joints = dice.integer(1, 3);
    for (int k = 0; k < joints; ++k) {
      const float joint = dice.uniform(0.f, canvas.sizef());
      canvas.rect(joint, y, joint + 2.f, y + board, dark * 0.35f);
    }
    y += board;
  }
  canvas.modulate(8, 3, 0.06f, seed + 43);
  return canvas.to_texture(name);
}

Texture plaid_fabric_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  const Colour ground(0.55f, 0.12f, 0.12f);
  Canvas canvas(size, ground);
  const std::vector<Colour> bands = {Colour(0.08f, 0.10f, 0.30f), Colour(0.10f, 0.35f, 0.20f),
                                     Colour(0.90f, 0.85f, 0.70f), Colour(0.85f, 0.70f, 0.15f)};
  struct Band {
    float start, width;
    Colour colour;
  };
  std::vector<Band> sett;  // the plaid's stripe sequence, shared by warp and weft
  float t = 0.f;
  while (t < canvas.sizef()) {
    const Band band{t, dice.uniform(6.f, 36.f), dice.pick(bands)};
    sett.push_back(band);
    t += band.width + dice.uniform(14.f, 40.f);
  }
  for (const Band& band : sett) {
    canvas.rect(band.start, 0.f, band.start + band.width, canvas.sizef(), band.colour, 0.6f);
    canvas.rect(0.f, band.start, canvas.sizef(), band.start + band.width, band.colour, 0.6f);
  }
  // Twill: diagonal ribs four pixels apart.
  canvas.each([&](int x, int y, Colour& p) { p *= ((x + y) / 3) % 2 ? 1.05f : 0.93f; });
  canvas.modulate(32, 2, 0.05f, seed + 47);
  return canvas.to_texture(name);
}

Texture upholstery_texture(const std::string& name, int size, std::uint64_t seed, const Colour& ground,
                           const Colour& pattern) {
  Dice dice(seed);
  Canvas canvas(size, ground);
  const float pitch = canvas.sizef() / 16.f;
  for (int row = 0; row < 16; ++row)
    for (int column = 0; column < 16; ++column) {
      const float cx = (column + 0.5f * (row % 2)) * pitch, cy = row * pitch;
      canvas.disc(cx, cy, pitch * dice.uniform(0.15f, 0.22f), pattern);
      const float xx = cx + 0.5f * pitch, xy = cy + 0.5f * pitch;
      const Colour cross = 0.5f * (ground + pattern) + Colour::Constant(0.25f);
      canvas.rect(xx - 0.2f * pitch, xy - 0.05f * pitch, xx + 0.2f * pitch, xy + 0.05f * pitch, cross);
      canvas.rect(xx - 0.05f * pitch, xy - 0.2f * pitch, xx + 0.05f * pitch, xy + 0.2f * pitch, cross);
    }
  canvas.each([&](int x, int y, Colour& p) { p *= (x / 2 + y / 2) % 2 ? 1.04f : 0.96f; });
  canvas.modulate(16, 3, 0.06f, seed + 53);
  return canvas.to_texture(name);
}

Texture ceramic_tiles_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.3f, 0.29f, 0.27f));
  const std::vector<Colour> glazes = {Colour(0.93f, 0.92f, 0.88f), Colour(0.15f, 0.30f, 0.65f),
                                      Colour(0.75f, 0.40f, 0.25f), Colour(0.20f, 0.55f, 0.55f)};
  const int tiles = 8;
  const float tile = canvas.sizef() / tiles, grout = 4.f * tile / 64.f;
  for (int ty = 0; ty < tiles; ++ty)
    for (int tx = 0; tx < tiles; ++tx) {
      const float x0 = tx * tile + grout * 0.5f, y0 = ty * tile + grout * 0.5f;
      const float x1 = x0 + tile - grout, y1 = y0 + tile - grout;
      const Colour glaze = dice.jitter(dice.pick(glazes), 0.08f);
      canvas.rect(x0, y0, x1, y1, glaze);
      canvas.rect(x0, y0, x1, y0 + 3.f, glaze * 1.15f);  // glaze highlight on the top edge
      if (dice.chance(0.45f)) {
        const Colour motif = luminance(glaze) > 0.5f ? Colour(0.12f, 0.2f, 0.55f) : Colour(0.95f, 0.92f, 0.85f);
        const float mx = 0.5f * (x0 + x1), my = 0.5f * (y0 + y1), r = 0.3f * tile;
        if (dice.chance(0.5f)) {
          canvas.polygon({Point(mx - r, my), Point(mx, my - r), Point(mx + r, my), Point(mx, my + r)}, motif);
        } else {
          canvas.rect(mx - r, my - 0.08f * tile, mx + r, my + 0.08f * tile, motif);
          canvas.rect(mx - 0.08f * tile, my - r, mx + 0.08f * tile, my + r, motif);
        }
      }
    }
  canvas.modulate(16, 2, 0.04f, seed + 59);
  return canvas.to_texture(name);
}

Texture book_spines_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.2f, 0.2f, 0.2f));
  // An atlas of 16 spines, each a full-height column: a book's spine face shows one column.
  const int spines = 16;
  const float width = canvas.sizef() / spines, h = canvas.sizef();
  for (int i = 0; i < spines; ++i) {
    const float x0 = i * width, x1 = x0 + width;
    const Colour cover = hsv(dice.unit(), dice.uniform(0.35f, 0.85f), dice.uniform(0.2f, 0.85f));
    const Colour ink = luminance(cover) > 0.45f ? Colour(0.08f, 0.08f, 0.08f) : Colour(0.95f, 0.92f, 0.8f);
    const Colour band = dice.chance(0.5f) ? Colour(0.85f, 0.68f, 0.25f) : ink;
    canvas.rect(x0, 0.f, x1, h, cover);
    for (float y : {0.06f * h, 0.1f * h, 0.88f * h, 0.92f * h}) canvas.rect(x0, y, x1, y + 0.012f * h, band);
    // Title: glyph blocks stacked down the spine; author label near the foot.
    float y = dice.uniform(0.18f, 0.26f) * h;
    const float y_end = dice.uniform(0.6f, 0.72f) * h;
    while (y < y_end) {
      const float glyph = dice.uniform(0.018f, 0.03f) * h;
      const float gw = dice.uniform(0.35f, 0.65f) * width;
      canvas.rect(x0 + 0.5f * (width - gw), y, x0 + 0.5f * (width + gw), y + glyph, ink);
      y += glyph + (dice.chance(0.2f) ? 0.03f * h : 0.008f * h);
    }
    canvas.rect(x0 + 0.2f * width, 0.76f * h, x1 - 0.2f * width, 0.82f * h, band);
    canvas.rect(x0, 0.f, x0 + 1.5f, h, Colour(0.05f, 0.05f, 0.05f));
  }
  canvas.modulate(16, 3, 0.06f, seed + 61);
  return canvas.to_texture(name);
}

Texture paper_edges_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.92f, 0.90f, 0.82f));
  float y = 0.f;
  while (y < canvas.sizef() - 3.f) {
    canvas.rect(0.f, y, canvas.sizef(), y + 1.2f, Colour(0.72f, 0.70f, 0.64f));
    y += dice.uniform(3.f, 6.f);
  }
  for (int i = 0; i < 6; ++i) {  // coloured markers and bookmarks
    const float x = dice.uniform(0.f, canvas.sizef());
    canvas.rect(x, 0.f, x + dice.uniform(4.f, 10.f), canvas.sizef(), hsv(dice.unit(), 0.7f, 0.7f));
  }
  canvas.modulate(8, 3, 0.06f, seed + 67);
  return canvas.to_texture(name);
}

Texture brushed_metal_texture(const std::string& name, int size, std::uint64_t seed, const Colour& tint) {
  Dice dice(seed);
  Canvas canvas(size, tint);
  const float inv = 1.f / canvas.sizef();
  const Fbm streaks(2, 128, 2, seed + 71);
  canvas.each([&](int x, int y, Colour& p) {
    const float streak = streaks((x + 0.5f) * inv, (y + 0.5f) * inv);
    p = tint * (0.8f + 0.35f * streak);
  });
  for (int i = 0; i < 60; ++i) {
    const float x = dice.uniform(0.f, canvas.sizef()), y = dice.uniform(0.f, canvas.sizef());
    const float a = dice.uniform(-0.4f, 0.4f) + (dice.chance(0.3f) ? 1.57f : 0.f), l = dice.uniform(10.f, 60.f);
    canvas.line(x, y, x + std::cos(a) * l, y + std::sin(a) * l, dice.uniform(1.f, 2.5f),
                dice.chance(0.5f) ? Colour(0.95f, 0.95f, 0.95f) : tint * 0.4f);
  }
  for (int i = 0; i < 30; ++i)
    canvas.disc(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()), dice.uniform(2.f, 4.f),
                tint * 0.35f);
  return canvas.to_texture(name);
}

Texture dark_plastic_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.14f, 0.14f, 0.15f));
  canvas.modulate(16, 3, 0.15f, seed + 73);
  const int specks = size * size / 150;
  for (int i = 0; i < specks; ++i)
    canvas.disc(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()), dice.uniform(1.f, 2.5f),
                dice.chance(0.7f) ? Colour(0.38f, 0.38f, 0.40f) : Colour(0.03f, 0.03f, 0.03f));
  for (int i = 0; i < 12; ++i) {
    const float x = dice.uniform(0.f, canvas.sizef()), y = dice.uniform(0.f, canvas.sizef());
    canvas.line(x, y, x + dice.uniform(-30.f, 30.f), y + dice.uniform(-30.f, 30.f), 1.5f, Colour(0.45f, 0.45f, 0.47f));
  }
  return canvas.to_texture(name);
}

Texture plaster_texture(const std::string& name, int size, std::uint64_t seed, const Colour& paint) {
  Dice dice(seed);
  Canvas canvas(size, paint);
  const float inv = 1.f / canvas.sizef();
  const Fbm stains(4, 4, 4, seed + 79);
  canvas.each([&](int x, int y, Colour& p) {
    const float stain = stains((x + 0.5f) * inv, (y + 0.5f) * inv);
    if (stain > 0.6f)
      p = p.cwiseProduct(Colour(0.78f, 0.72f, 0.62f));
    else if (stain > 0.56f)
      p = p.cwiseProduct(Colour(0.6f, 0.55f, 0.48f));  // tide mark at the edge
  });
  // Brush marks: short streaks a little lighter or darker than the paint.
  for (int i = 0; i < size * size / 400; ++i) {
    const float x = dice.uniform(0.f, canvas.sizef()), y = dice.uniform(0.f, canvas.sizef());
    const float a = dice.uniform(0.f, kPi), l = dice.uniform(8.f, 24.f);
    canvas.line(x, y, x + std::cos(a) * l, y + std::sin(a) * l, dice.uniform(2.f, 5.f),
                paint * (dice.chance(0.5f) ? 0.7f : 1.15f));
  }
  // Hairline cracks: random walks.
  for (int i = 0; i < 8; ++i) {
    std::vector<Point> crack = {Point(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()))};
    float heading = dice.uniform(0.f, 2.f * kPi);
    for (int k = 0; k < 14; ++k) {
      heading += dice.uniform(-0.6f, 0.6f);
      const float step = dice.uniform(6.f, 14.f);
      crack.push_back(crack.back() + step * Point(std::cos(heading), std::sin(heading)));
    }
    canvas.polyline(crack, 1.6f, paint * 0.35f);
  }
  for (int i = 0; i < size * size / 900; ++i)
    canvas.disc(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()), dice.uniform(1.f, 2.2f),
                paint * 0.4f);
  return canvas.to_texture(name);
}

Texture leaf_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.20f, 0.45f, 0.15f));
  canvas.modulate(8, 3, 0.2f, seed + 83);
  const float pitch = canvas.sizef() / 4.f;
  for (int i = 0; i < 4; ++i) {
    const float y = (i + 0.5f) * pitch;
    canvas.rect(0.f, y - 1.5f, canvas.sizef(), y + 1.5f, Colour(0.55f, 0.72f, 0.35f));
    for (float x = 0.f; x < canvas.sizef(); x += pitch / 3.f) {
      canvas.line(x, y, x + pitch * 0.3f, y - pitch * 0.4f, 1.5f, Colour(0.45f, 0.65f, 0.3f));
      canvas.line(x, y, x + pitch * 0.3f, y + pitch * 0.4f, 1.5f, Colour(0.45f, 0.65f, 0.3f));
    }
  }
  for (int i = 0; i < 40; ++i)
    canvas.disc(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()), dice.uniform(1.5f, 4.f),
                dice.chance(0.5f) ? Colour(0.65f, 0.6f, 0.2f) : Colour(0.1f, 0.22f, 0.08f));
  return canvas.to_texture(name);
}

Texture terracotta_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.72f, 0.38f, 0.22f));
  canvas.modulate(8, 3, 0.12f, seed + 89);
  const float s = canvas.sizef(), band0 = 0.3f * s, band1 = 0.7f * s;
  canvas.rect(0.f, band0, s, band1, Colour(0.90f, 0.85f, 0.70f));
  const int teeth = 8;
  const float w = s / teeth;
  for (int i = 0; i < teeth; ++i) {
    const float x = i * w;
    canvas.polygon({Point(x, band1), Point(x + w, band1), Point(x + 0.5f * w, band0 + 0.15f * s)},
                   Colour(0.30f, 0.15f, 0.08f));
    canvas.disc(x + 0.5f * w, band0 + 0.07f * s, 0.04f * s, Colour(0.15f, 0.3f, 0.45f));
  }
  canvas.rect(0.f, band0 - 6.f, s, band0, Colour(0.25f, 0.12f, 0.06f));
  canvas.rect(0.f, band1, s, band1 + 6.f, Colour(0.25f, 0.12f, 0.06f));
  for (int i = 0; i < 30; ++i)
    canvas.disc(dice.uniform(0.f, s), dice.uniform(0.f, band0 - 8.f), dice.uniform(1.5f, 3.f),
                Colour(0.5f, 0.25f, 0.14f));
  return canvas.to_texture(name);
}

Texture soil_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.22f, 0.14f, 0.09f));
  canvas.modulate(16, 3, 0.25f, seed + 97);
  for (int i = 0; i < size * size / 200; ++i) {
    const float g = dice.uniform(0.35f, 0.75f);
    canvas.ellipse(dice.uniform(0.f, canvas.sizef()), dice.uniform(0.f, canvas.sizef()), dice.uniform(2.f, 6.f),
                   dice.uniform(1.5f, 4.f), dice.uniform(0.f, kPi), Colour(g, g * 0.92f, g * 0.85f));
  }
  return canvas.to_texture(name);
}

Texture lampshade_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.90f, 0.84f, 0.70f));
  canvas.each([&](int x, int y, Colour& p) { p *= (x / 2 + y / 2) % 2 ? 1.03f : 0.97f; });
  const float pitch = canvas.sizef() / 8.f;
  for (int row = 0; row < 8; ++row)
    for (int column = 0; column < 8; ++column) {
      const float cx = (column + 0.5f * (row % 2)) * pitch, cy = (row + 0.5f) * pitch;
      const float a = dice.uniform(0.f, kPi);
      canvas.ellipse(cx, cy, 0.3f * pitch, 0.1f * pitch, a, Colour(0.45f, 0.30f, 0.20f));
      canvas.ellipse(cx, cy, 0.3f * pitch, 0.1f * pitch, a + 1.2f, Colour(0.30f, 0.40f, 0.25f));
    }
  return canvas.to_texture(name);
}

Texture mesh_fabric_texture(const std::string& name, int size, std::uint64_t seed) {
  Canvas canvas(size, Colour(0.12f, 0.12f, 0.14f));
  const float pitch = canvas.sizef() / 16.f, s = canvas.sizef();
  for (int i = -16; i < 32; ++i) {
    const float x = i * pitch;
    canvas.line(x, 0.f, x + s, s, 3.f, Colour(0.40f, 0.40f, 0.44f));
    canvas.line(x, s, x + s, 0.f, 3.f, Colour(0.40f, 0.40f, 0.44f));
  }
  canvas.modulate(8, 2, 0.1f, seed + 101);
  return canvas.to_texture(name);
}

Texture poster_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  const float hue = dice.unit();
  const bool dark_ground = dice.chance(0.5f);
  const Colour ground = dark_ground ? hsv(hue, 0.6f, 0.2f) : hsv(hue, 0.15f, 0.92f);
  Canvas canvas(size, ground);
  const float s = canvas.sizef();
  std::vector<Colour> palette;
  for (int i = 0; i < 4; ++i)
    palette.push_back(hsv(hue + dice.uniform(0.1f, 0.9f), dice.uniform(0.5f, 0.95f), dice.uniform(0.35f, 0.95f)));
  palette.push_back(dark_ground ? Colour(0.95f, 0.95f, 0.92f) : Colour(0.08f, 0.08f, 0.1f));
  // Blobs: thresholded noise over the whole sheet.
  const float inv = 1.f / s;
  const Colour blob = dice.pick(palette);
  const Fbm blobs(3, 3, 3, seed + 103);
  canvas.each([&](int x, int y, Colour& p) {
    if (blobs((x + 0.5f) * inv, (y + 0.5f) * inv) > 0.6f) p = blob;
  });
  for (int i = 0; i < dice.integer(2, 4); ++i) {  // bold stripes
    const float y = dice.uniform(0.1f, 0.8f) * s, h = dice.uniform(0.02f, 0.06f) * s;
    canvas.rect(0.f, y, s, y + h, dice.pick(palette));
  }
  for (int i = 0; i < dice.integer(4, 8); ++i) {  // shapes
    const float x = dice.uniform(0.1f, 0.9f) * s, y = dice.uniform(0.15f, 0.75f) * s,
                r = dice.uniform(0.04f, 0.15f) * s;
    const Colour c = dice.pick(palette);
    switch (dice.integer(0, 3)) {
      case 0: canvas.disc(x, y, r, c); break;
      case 1: canvas.rect(x - r, y - 0.7f * r, x + r, y + 0.7f * r, c); break;
      case 2: canvas.polygon({Point(x - r, y + r), Point(x + r, y + r), Point(x, y - r)}, c); break;
      default: canvas.ring(x, y, 0.6f * r, r, c); break;
    }
  }
  // Title and body text.
  const Colour ink = palette.back();
  const float title_y = dice.chance(0.5f) ? 0.05f * s : 0.8f * s;
  text_line(canvas, dice, 0.08f * s, title_y, 0.84f * s, 0.07f * s, ink);
  for (int line = 0; line < dice.integer(4, 8); ++line)
    text_line(canvas, dice, 0.08f * s, (title_y < 0.5f * s ? 0.8f * s : 0.06f * s) + line * 0.022f * s, 0.84f * s,
              0.013f * s, ink);
  canvas.frame(0.f, 0.f, s, s, 0.025f * s, Colour(0.96f, 0.96f, 0.94f));
  return canvas.to_texture(name);
}

Texture screen_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.1f, 0.3f, 0.5f));
  const float s = canvas.sizef(), inv = 1.f / s;
  const float hue = dice.unit();
  const Fbm wallpaper(2, 2, 3, seed + 107);
  canvas.each([&](int x, int y, Colour& p) {
    const float n = wallpaper((x + 0.5f) * inv, (y + 0.5f) * inv);
    p = hsv(hue + 0.2f * n, 0.6f, 0.25f + 0.5f * n);
  });
  for (int i = 0; i < 6; ++i) {  // desktop icons with labels
    const float y = 0.05f * s + i * 0.11f * s;
    canvas.rect(0.03f * s, y, 0.09f * s, y + 0.06f * s, hsv(dice.unit(), 0.7f, 0.9f));
    canvas.rect(0.02f * s, y + 0.07f * s, 0.10f * s, y + 0.085f * s, Colour(0.95f, 0.95f, 0.95f));
  }
  for (int w = 0; w < 3; ++w) {  // application windows
    const float x0 = dice.uniform(0.15f, 0.45f) * s, y0 = dice.uniform(0.05f, 0.4f) * s;
    const float x1 = std::min(x0 + dice.uniform(0.35f, 0.5f) * s, 0.97f * s);
    const float y1 = std::min(y0 + dice.uniform(0.3f, 0.45f) * s, 0.88f * s);
    canvas.rect(x0, y0, x1, y1, Colour(0.96f, 0.96f, 0.95f));
    canvas.rect(x0, y0, x1, y0 + 0.04f * s, hsv(dice.unit(), 0.6f, 0.5f));
    for (int b = 0; b < 3; ++b)
      canvas.disc(x1 - (0.02f + 0.03f * b) * s, y0 + 0.02f * s, 0.008f * s, Colour(0.95f, 0.8f, 0.3f));
    if (dice.chance(0.5f)) {  // a chart
      const int bars = dice.integer(5, 9);
      const float bw = (x1 - x0 - 0.04f * s) / bars;
      for (int b = 0; b < bars; ++b) {
        const float h = dice.uniform(0.1f, 0.9f) * (y1 - y0 - 0.1f * s);
        canvas.rect(x0 + 0.02f * s + b * bw, y1 - 0.02f * s - h, x0 + 0.02f * s + (b + 0.7f) * bw, y1 - 0.02f * s,
                    hsv(hue + 0.1f * b, 0.7f, 0.7f));
      }
    } else {
      for (float y = y0 + 0.06f * s; y < y1 - 0.03f * s; y += 0.028f * s)
        text_line(canvas, dice, x0 + 0.02f * s, y, x1 - x0 - 0.04f * s, 0.014f * s, Colour(0.1f, 0.1f, 0.12f));
    }
  }
  canvas.rect(0.f, 0.93f * s, s, s, Colour(0.08f, 0.08f, 0.1f));  // task bar
  for (int i = 0; i < 8; ++i)
    canvas.rect((0.02f + 0.06f * i) * s, 0.945f * s, (0.06f + 0.06f * i) * s, 0.985f * s, hsv(dice.unit(), 0.5f, 0.8f));
  return canvas.to_texture(name);
}

Texture tv_picture_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.4f, 0.6f, 0.9f));
  const float s = canvas.sizef();
  canvas.each([&](int, int y, Colour& p) {
    const float t = static_cast<float>(y) / s;
    p = Colour(0.25f, 0.45f, 0.85f) * (1.f - t) + Colour(0.95f, 0.8f, 0.6f) * t;
  });
  canvas.disc(0.75f * s, 0.2f * s, 0.07f * s, Colour(1.f, 0.9f, 0.4f));
  for (int i = 0; i < 5; ++i)
    canvas.ellipse(dice.uniform(0.f, s), dice.uniform(0.05f, 0.3f) * s, dice.uniform(0.05f, 0.12f) * s,
                   dice.uniform(0.02f, 0.04f) * s, 0.f, Colour(0.97f, 0.97f, 0.97f));
  for (int layer = 0; layer < 3; ++layer) {  // hills, far to near
    const float base = (0.45f + 0.12f * layer) * s, amplitude = 0.06f * s, phase = dice.uniform(0.f, 6.f);
    const Colour colour = Colour(0.15f, 0.35f - 0.07f * layer, 0.2f) * (1.2f - 0.2f * layer);
    for (int x = 0; x < size; ++x) {
      const float top =
          base + amplitude * std::sin(phase + 6.f * x / s) + 0.5f * amplitude * std::sin(phase * 2.f + 17.f * x / s);
      canvas.rect(x, top, x + 1, s, colour);
    }
  }
  for (int i = 0; i < 12; ++i) {  // trees
    const float x = dice.uniform(0.f, s), y = dice.uniform(0.65f, 0.85f) * s, h = dice.uniform(0.06f, 0.12f) * s;
    canvas.rect(x - 0.006f * s, y, x + 0.006f * s, y + 0.03f * s, Colour(0.3f, 0.2f, 0.1f));
    canvas.polygon({Point(x - 0.35f * h, y), Point(x + 0.35f * h, y), Point(x, y - h)}, Colour(0.05f, 0.25f, 0.1f));
  }
  const float hx = 0.3f * s, hy = 0.62f * s;  // a house
  canvas.rect(hx, hy, hx + 0.15f * s, hy + 0.1f * s, Colour(0.9f, 0.85f, 0.75f));
  canvas.polygon({Point(hx - 0.02f * s, hy), Point(hx + 0.17f * s, hy), Point(hx + 0.075f * s, hy - 0.07f * s)},
                 Colour(0.6f, 0.15f, 0.1f));
  canvas.rect(hx + 0.02f * s, hy + 0.02f * s, hx + 0.05f * s, hy + 0.05f * s, Colour(0.2f, 0.3f, 0.5f));
  canvas.rect(hx + 0.1f * s, hy + 0.02f * s, hx + 0.13f * s, hy + 0.05f * s, Colour(0.2f, 0.3f, 0.5f));
  canvas.rect(0.f, 0.88f * s, s, 0.97f * s, Colour(0.05f, 0.05f, 0.05f), 0.8f);  // subtitles
  text_line(canvas, dice, 0.1f * s, 0.9f * s, 0.8f * s, 0.04f * s, Colour(0.95f, 0.95f, 0.9f));
  text_line(canvas, dice, 0.82f * s, 0.04f * s, 0.14f * s, 0.04f * s, Colour(1.f, 1.f, 1.f));  // channel logo
  return canvas.to_texture(name);
}

Texture outdoor_view_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.5f, 0.7f, 0.95f));
  const float s = canvas.sizef();
  canvas.each([&](int, int y, Colour& p) {
    const float t = static_cast<float>(y) / s;
    p = Colour(0.35f, 0.55f, 0.9f) * (1.f - t) + Colour(0.85f, 0.9f, 0.97f) * t;
  });
  for (int i = 0; i < 6; ++i)
    canvas.ellipse(dice.uniform(0.f, s), dice.uniform(0.03f, 0.2f) * s, dice.uniform(0.06f, 0.15f) * s,
                   dice.uniform(0.02f, 0.05f) * s, 0.f, Colour(0.98f, 0.98f, 0.98f));
  // Buildings: facades with a grid of windows, some lit.
  float x = -0.05f * s;
  while (x < s) {
    const float w = dice.uniform(0.12f, 0.3f) * s, top = dice.uniform(0.15f, 0.45f) * s;
    const Colour facade =
        dice.jitter(dice.pick(std::vector<Colour>{Colour(0.75f, 0.7f, 0.62f), Colour(0.55f, 0.5f, 0.48f),
                                                  Colour(0.7f, 0.45f, 0.35f), Colour(0.85f, 0.83f, 0.8f)}),
                    0.1f);
    canvas.rect(x, top, x + w, s, facade);
    canvas.rect(x, top, x + w, top + 0.015f * s, facade * 0.6f);
    const float pane = 0.03f * s, gap = 0.022f * s;
    for (float wy = top + 0.03f * s; wy < 0.85f * s; wy += pane + gap)
      for (float wx = x + 0.02f * s; wx + pane < x + w - 0.01f * s; wx += pane + gap)
        canvas.rect(wx, wy, wx + pane, wy + 1.3f * pane,
                    dice.chance(0.25f) ? Colour(0.95f, 0.85f, 0.5f) : Colour(0.15f, 0.2f, 0.28f));
    x += w + dice.uniform(0.f, 0.04f) * s;
  }
  for (int i = 0; i < 25; ++i)  // tree crowns in front
    canvas.disc(dice.uniform(0.f, s), dice.uniform(0.75f, 0.95f) * s, dice.uniform(0.03f, 0.07f) * s,
                Colour(0.1f, 0.3f + dice.uniform(0.f, 0.15f), 0.1f));
  return canvas.to_texture(name);
}

Texture rug_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  const Colour red(0.55f, 0.12f, 0.12f), navy(0.10f, 0.12f, 0.30f), cream(0.90f, 0.84f, 0.68f),
      gold(0.80f, 0.60f, 0.20f);
  Canvas canvas(size, red);
  const float s = canvas.sizef(), b = 0.06f * s;
  canvas.frame(0.f, 0.f, s, s, b, navy);
  for (float t = 0.5f * b; t < s; t += b) {  // diamonds along the outer border
    for (const Point& c : {Point(t, 0.5f * b), Point(t, s - 0.5f * b), Point(0.5f * b, t), Point(s - 0.5f * b, t)})
      canvas.polygon({Point(c.x() - 0.3f * b, c.y()), Point(c.x(), c.y() - 0.3f * b), Point(c.x() + 0.3f * b, c.y()),
                      Point(c.x(), c.y() + 0.3f * b)},
                     cream);
  }
  canvas.frame(b, b, s - b, s - b, 0.3f * b, cream);
  canvas.frame(1.3f * b, 1.3f * b, s - 1.3f * b, s - 1.3f * b, 0.1f * b, gold);
  const int cells = 6;
  const float field0 = 1.6f * b, cell = (s - 2.f * field0) / cells;
  for (int cy = 0; cy < cells; ++cy)
    for (int cx = 0; cx < cells; ++cx) {
      const float mx = field0 + (cx + 0.5f) * cell, my = field0 + (cy + 0.5f) * cell, r = 0.42f * cell;
      const Colour outer = (cx + cy) % 2 ? navy : gold, inner = (cx + cy) % 2 ? cream : navy;
      canvas.polygon({Point(mx - r, my), Point(mx, my - r), Point(mx + r, my), Point(mx, my + r)}, outer);
      canvas.rect(mx - 0.45f * r, my - 0.45f * r, mx + 0.45f * r, my + 0.45f * r, inner);
      canvas.disc(mx, my, 0.2f * r, red);
      canvas.disc(field0 + cx * cell, field0 + cy * cell, 0.08f * cell, cream);
    }
  canvas.modulate(64, 2, 0.08f, seed + 109);
  return canvas.to_texture(name);
}

Texture keyboard_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.12f, 0.12f, 0.13f));
  const float s = canvas.sizef();
  const int rows = 6, columns = 15;
  const float kh = s / rows, kw = s / columns, gap = 0.12f;
  for (int row = 0; row < rows; ++row) {
    int column = 0;
    while (column < columns) {
      int span = 1;
      if (row == 5 && column == 4) span = 6;  // space bar
      if (row > 0 && row < 5 && column == 0 && dice.chance(0.5f)) span = 2;
      span = std::min(span, columns - column);
      const float x0 = (column + gap) * kw, x1 = (column + span - gap) * kw;
      const float y0 = (row + gap) * kh, y1 = (row + 1 - gap) * kh;
      canvas.rect(x0, y0, x1, y1, row == 0 ? Colour(0.6f, 0.62f, 0.66f) : Colour(0.85f, 0.85f, 0.86f));
      canvas.rect(x0, y1 - 0.1f * kh, x1, y1, Colour(0.5f, 0.5f, 0.52f));
      if (span < 3) {  // a legend in the key's corner
        const float lx = x0 + 0.18f * kw, ly = y0 + 0.15f * kh;
        canvas.rect(lx, ly, lx + 0.1f * kw, ly + 0.35f * kh, Colour(0.1f, 0.1f, 0.1f));
        if (dice.chance(0.6f)) canvas.rect(lx, ly, lx + 0.35f * kw, ly + 0.08f * kh, Colour(0.1f, 0.1f, 0.1f));
      }
      column += span;
    }
  }
  return canvas.to_texture(name);
}

Texture door_texture(const std::string& name, int size, std::uint64_t seed) {
  Texture grain = wood_texture(name, size, seed, Colour(0.72f, 0.5f, 0.3f), Colour(0.45f, 0.28f, 0.15f));
  Canvas canvas(size, Colour::Zero());
  // Grain runs vertically on a door: transpose the board texture.
  canvas.each([&](int x, int y, Colour& p) {
    const std::size_t i = (static_cast<std::size_t>(x) * size + y) * 3;
    p = Colour(grain.rgb[i], grain.rgb[i + 1], grain.rgb[i + 2]) / 255.f;
  });
  const float s = canvas.sizef();
  // Six raised panels: lit top and left bevels, shadowed bottom and right.
  for (int row = 0; row < 3; ++row)
    for (int column = 0; column < 2; ++column) {
      const float x0 = (0.12f + 0.42f * column) * s, x1 = x0 + 0.34f * s;
      const float y0 = (0.06f + 0.31f * row) * s, y1 = y0 + 0.26f * s, bevel = 0.03f * s;
      canvas.rect(x0, y0, x1, y0 + bevel, Colour(0.95f, 0.8f, 0.6f), 0.6f);
      canvas.rect(x0, y0, x0 + bevel, y1, Colour(0.95f, 0.8f, 0.6f), 0.6f);
      canvas.rect(x0, y1 - bevel, x1, y1, Colour(0.1f, 0.05f, 0.02f), 0.6f);
      canvas.rect(x1 - bevel, y0 + bevel, x1, y1, Colour(0.1f, 0.05f, 0.02f), 0.6f);
      canvas.frame(x0 - 3.f, y0 - 3.f, x1 + 3.f, y1 + 3.f, 3.f, Colour(0.15f, 0.08f, 0.04f));
    }
  return canvas.to_texture(name);
}

Texture whiteboard_texture(const std::string& name, int size, std::uint64_t seed) {
  Dice dice(seed);
  Canvas canvas(size, Colour(0.95f, 0.95f, 0.94f));
  const float s = canvas.sizef();
  const std::vector<Colour> markers = {Colour(0.05f, 0.05f, 0.08f), Colour(0.1f, 0.2f, 0.7f), Colour(0.75f, 0.1f, 0.1f),
                                       Colour(0.1f, 0.5f, 0.2f)};
  std::vector<Point> box_centres;
  for (int i = 0; i < 6; ++i) {  // boxes with text, joined by arrows
    const Colour ink = dice.pick(markers);
    const float x0 = dice.uniform(0.05f, 0.7f) * s, y0 = dice.uniform(0.05f, 0.75f) * s;
    const float w = dice.uniform(0.15f, 0.25f) * s, h = dice.uniform(0.1f, 0.18f) * s;
    canvas.frame(x0, y0, x0 + w, y0 + h, 3.f, ink);
    for (float y = y0 + 0.02f * s; y < y0 + h - 0.03f * s; y += 0.03f * s)
      text_line(canvas, dice, x0 + 0.015f * s, y, w - 0.03f * s, 0.018f * s, ink);
    box_centres.emplace_back(x0 + 0.5f * w, y0 + 0.5f * h);
  }
  for (std::size_t i = 0; i + 1 < box_centres.size(); i += 2) {
    const Point a = box_centres[i], b = box_centres[i + 1];
    canvas.line(a.x(), a.y(), b.x(), b.y(), 3.f, markers[0]);
    const Point d = (b - a).normalized(), n(-d.y(), d.x());
    canvas.polygon({b, Point(b - 14.f * d + 7.f * n), Point(b - 14.f * d - 7.f * n)}, markers[0]);
  }
  for (int i = 0; i < 3; ++i)
    canvas.ring(dice.uniform(0.1f, 0.9f) * s, dice.uniform(0.1f, 0.9f) * s, 0.04f * s, 0.04f * s + 3.f,
                dice.pick(markers));
  for (int i = 0; i < 5; ++i)  // handwriting
    text_line(canvas, dice, 0.05f * s, (0.82f + 0.03f * i) * s, 0.6f * s, 0.02f * s, dice.pick(markers));
  return canvas.to_texture(name);
}

}  // namespace panoscan::scenes
