// Internal to panoscan_scenes: the drawing kit of the procedural textures. A square RGB canvas
// whose shapes wrap around its edges (so tiling textures are seamless), periodic fractal noise,
// the random draws of one texture, and text-like marks.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "panoscan/core/mesh.h"
#include "panoscan/core/random.h"

namespace panoscan::scenes {

using Colour = Eigen::Vector3f;  // sRGB-ish in [0, 1]
using Point = Eigen::Vector2f;   // canvas pixel coordinates

// ---------------------------------------------------------------------------------------------
// Periodic value noise: lattice values hashed from integer coordinates taken modulo the period, so
// a texture whose noise coordinates span whole periods tiles without a seam.

inline float lattice_value(int ix, int iy, int period_x, int period_y, std::uint64_t seed) {
  ix %= period_x;
  if (ix < 0) ix += period_x;
  iy %= period_y;
  if (iy < 0) iy += period_y;
  const std::uint64_t h = mix64(seed ^ (static_cast<std::uint64_t>(ix) * 0x9E3779B97F4A7C15ull) ^
                                (static_cast<std::uint64_t>(iy) * 0xC2B2AE3D27D4EB4Full));
  return static_cast<float>(h >> 40) / static_cast<float>(1u << 24);
}

inline float smooth(float t) { return t * t * (3.f - 2.f * t); }

// Fractal noise in [0, 1] at texture coordinates (u, v) in [0, 1): `cells_x` x `cells_y` lattice
// cells across the texture at the coarsest octave, doubling per octave. Tiles over [0, 1). The
// lattice values are tabulated once, so that evaluating it per pixel costs no hashing.
class Fbm {
 public:
  Fbm(int cells_x, int cells_y, int octaves, std::uint64_t seed) {
    float amplitude = 1.f, norm = 0.f;
    for (int o = 0; o < octaves; ++o) {
      Octave octave;
      octave.period_x = cells_x << o;
      octave.period_y = cells_y << o;
      octave.amplitude = amplitude;
      octave.values.resize(static_cast<std::size_t>(octave.period_x) * octave.period_y);
      const std::uint64_t octave_seed = seed + 7919u * static_cast<unsigned>(o);
      for (int iy = 0; iy < octave.period_y; ++iy)
        for (int ix = 0; ix < octave.period_x; ++ix)
          octave.values[static_cast<std::size_t>(iy) * octave.period_x + ix] =
              lattice_value(ix, iy, octave.period_x, octave.period_y, octave_seed);
      octaves_.push_back(std::move(octave));
      norm += amplitude;
      amplitude *= 0.5f;
    }
    inv_norm_ = 1.f / norm;
  }

  float operator()(float u, float v) const {
    float sum = 0.f;
    for (const Octave& o : octaves_) {
      const float x = u * o.period_x, y = v * o.period_y;
      const float fx = std::floor(x), fy = std::floor(y);
      const float tx = smooth(x - fx), ty = smooth(y - fy);
      int ix0 = static_cast<int>(fx) % o.period_x, iy0 = static_cast<int>(fy) % o.period_y;
      if (ix0 < 0) ix0 += o.period_x;
      if (iy0 < 0) iy0 += o.period_y;
      const int ix1 = ix0 + 1 == o.period_x ? 0 : ix0 + 1, iy1 = iy0 + 1 == o.period_y ? 0 : iy0 + 1;
      const float* row0 = &o.values[static_cast<std::size_t>(iy0) * o.period_x];
      const float* row1 = &o.values[static_cast<std::size_t>(iy1) * o.period_x];
      const float top = row0[ix0] + (row0[ix1] - row0[ix0]) * tx;
      const float bottom = row1[ix0] + (row1[ix1] - row1[ix0]) * tx;
      sum += o.amplitude * (top + (bottom - top) * ty);
    }
    return sum * inv_norm_;
  }

 private:
  struct Octave {
    int period_x = 1, period_y = 1;
    float amplitude = 1.f;
    std::vector<float> values;
  };
  std::vector<Octave> octaves_;
  float inv_norm_ = 1.f;
};

inline Colour hsv(float h, float s, float v) {
  h = h - std::floor(h);
  const float c = v * s;
  const float hp = h * 6.f;
  const float x = c * (1.f - std::abs(std::fmod(hp, 2.f) - 1.f));
  Colour rgb;
  if (hp < 1.f)
    rgb = Colour(c, x, 0.f);
  else if (hp < 2.f)
    rgb = Colour(x, c, 0.f);
  else if (hp < 3.f)
    rgb = Colour(0.f, c, x);
  else if (hp < 4.f)
    rgb = Colour(0.f, x, c);
  else if (hp < 5.f)
    rgb = Colour(x, 0.f, c);
  else
    rgb = Colour(c, 0.f, x);
  return rgb + Colour::Constant(v - c);
}

inline float luminance(const Colour& c) { return 0.299f * c.x() + 0.587f * c.y() + 0.114f * c.z(); }

// Random draws for one texture: the stream is keyed by the texture's seed only.
class Dice {
 public:
  explicit Dice(std::uint64_t seed) : stream_(seed, 0, 0, RandomPurpose::kScene) {}
  float uniform(float lo, float hi) { return static_cast<float>(stream_.uniform(lo, hi)); }
  float unit() { return static_cast<float>(stream_.uniform()); }
  int integer(int lo, int hi_inclusive) { return stream_.uniform_int(lo, hi_inclusive); }
  bool chance(float p) { return stream_.uniform() < p; }
  template <typename T>
  const T& pick(const std::vector<T>& items) {
    return items[static_cast<std::size_t>(integer(0, static_cast<int>(items.size()) - 1))];
  }
  Colour jitter(const Colour& c, float amount) {
    return (c * uniform(1.f - amount, 1.f + amount)).cwiseMax(0.f).cwiseMin(1.f);
  }

 private:
  RandomStream stream_;
};

// ---------------------------------------------------------------------------------------------
// A square float RGB canvas. Every shape wraps around the edges (so tiling textures stay seamless)
// and is drawn with 2x2 supersampling, which softens the edges a little against aliasing.
class Canvas {
 public:
  Canvas(int size, const Colour& ground) : size_(size), pixels_(static_cast<std::size_t>(size) * size, ground) {}

  int size() const { return size_; }
  float sizef() const { return static_cast<float>(size_); }
  Colour& at(int x, int y) { return pixels_[static_cast<std::size_t>(wrap(y)) * size_ + wrap(x)]; }

  // Calls f(x, y, pixel) for every pixel.
  template <typename F>
  void each(F f) {
    for (int y = 0; y < size_; ++y)
      for (int x = 0; x < size_; ++x) f(x, y, pixels_[static_cast<std::size_t>(y) * size_ + x]);
  }

  // Paints `colour` over the part of box [x0, x1] x [y0, y1] where inside(x, y) holds.
  template <typename Inside>
  void fill(float x0, float y0, float x1, float y1, const Colour& colour, float alpha, Inside inside) {
    const int ix0 = static_cast<int>(std::floor(x0)), ix1 = static_cast<int>(std::ceil(x1));
    const int iy0 = static_cast<int>(std::floor(y0)), iy1 = static_cast<int>(std::ceil(y1));
    static const float kSub[2] = {0.25f, 0.75f};
    for (int y = iy0; y < iy1; ++y)
      for (int x = ix0; x < ix1; ++x) {
        int covered = 0;
        for (float sy : kSub)
          for (float sx : kSub) covered += inside(x + sx, y + sy) ? 1 : 0;
        if (covered == 0) continue;
        const float a = alpha * 0.25f * static_cast<float>(covered);
        Colour& p = at(x, y);
        p = p * (1.f - a) + colour * a;
      }
  }

  void rect(float x0, float y0, float x1, float y1, const Colour& colour, float alpha = 1.f) {
    fill(x0, y0, x1, y1, colour, alpha, [&](float x, float y) { return x >= x0 && x < x1 && y >= y0 && y < y1; });
  }
  // Outline of a rectangle, `width` pixels wide, inside the rectangle.
  void frame(float x0, float y0, float x1, float y1, float width, const Colour& colour, float alpha = 1.f) {
    rect(x0, y0, x1, y0 + width, colour, alpha);
    rect(x0, y1 - width, x1, y1, colour, alpha);
    rect(x0, y0 + width, x0 + width, y1 - width, colour, alpha);
    rect(x1 - width, y0 + width, x1, y1 - width, colour, alpha);
  }
  void ellipse(float cx, float cy, float rx, float ry, float angle, const Colour& colour, float alpha = 1.f) {
    const float c = std::cos(angle), s = std::sin(angle), r = std::max(rx, ry);
    fill(cx - r, cy - r, cx + r, cy + r, colour, alpha, [&](float x, float y) {
      const float dx = x - cx, dy = y - cy;
      const float a = (c * dx + s * dy) / rx, b = (-s * dx + c * dy) / ry;
      return a * a + b * b <= 1.f;
    });
  }
  void disc(float cx, float cy, float r, const Colour& colour, float alpha = 1.f) {
    ellipse(cx, cy, r, r, 0.f, colour, alpha);
  }
  void ring(float cx, float cy, float r_in, float r_out, const Colour& colour, float alpha = 1.f) {
    fill(cx - r_out, cy - r_out, cx + r_out, cy + r_out, colour, alpha, [&](float x, float y) {
      const float d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
      return d2 <= r_out * r_out && d2 >= r_in * r_in;
    });
  }
  // Convex polygon, either winding.
  void polygon(const std::vector<Point>& points, const Colour& colour, float alpha = 1.f) {
    Point lo = points[0], hi = points[0];
    for (const Point& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    fill(lo.x(), lo.y(), hi.x(), hi.y(), colour, alpha, [&](float x, float y) {
      bool has_positive = false, has_negative = false;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Point& a = points[i];
        const Point& b = points[(i + 1) % points.size()];
        const float side = (b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x());
        if (side > 0.f) has_positive = true;
        if (side < 0.f) has_negative = true;
      }
      return !(has_positive && has_negative);
    });
  }
  void line(float x0, float y0, float x1, float y1, float width, const Colour& colour, float alpha = 1.f) {
    const float half = 0.5f * width;
    const Point a(x0, y0), b(x1, y1), d = b - a;
    const float length2 = std::max(d.squaredNorm(), 1e-6f);
    fill(std::min(x0, x1) - half, std::min(y0, y1) - half, std::max(x0, x1) + half, std::max(y0, y1) + half, colour,
         alpha, [&](float x, float y) {
           const Point p(x, y);
           const float t = std::clamp((p - a).dot(d) / length2, 0.f, 1.f);
           return (p - (a + t * d)).squaredNorm() <= half * half;
         });
  }
  void polyline(const std::vector<Point>& points, float width, const Colour& colour, float alpha = 1.f) {
    for (std::size_t i = 0; i + 1 < points.size(); ++i)
      line(points[i].x(), points[i].y(), points[i + 1].x(), points[i + 1].y(), width, colour, alpha);
  }

  // Multiplies every pixel by 1 + amplitude * (2 * noise - 1): uneven paint, dye, wear.
  void modulate(int cells, int octaves, float amplitude, std::uint64_t seed) {
    const float inv = 1.f / sizef();
    const Fbm noise(cells, cells, octaves, seed);
    each([&](int x, int y, Colour& p) {
      const float n = noise((x + 0.5f) * inv, (y + 0.5f) * inv);
      p *= 1.f + amplitude * (2.f * n - 1.f);
    });
  }

  Texture to_texture(const std::string& name) const {
    Texture texture;
    texture.name = name;
    texture.width = size_;
    texture.height = size_;
    texture.rgb.resize(static_cast<std::size_t>(size_) * size_ * 3);
    for (std::size_t i = 0; i < pixels_.size(); ++i)
      for (int c = 0; c < 3; ++c)
        texture.rgb[3 * i + c] = static_cast<std::uint8_t>(std::lround(255.f * std::clamp(pixels_[i][c], 0.f, 1.f)));
    return texture;
  }

 private:
  int wrap(int v) const {
    v %= size_;
    return v < 0 ? v + size_ : v;
  }
  int size_;
  std::vector<Colour> pixels_;
};

// Text-like marks on one line: words of glyphs, each glyph one to three strokes, so that they read
// as print from a distance and give corners up close.
inline void text_line(Canvas& canvas, Dice& dice, float x, float y, float width, float height, const Colour& ink) {
  const float glyph_width = 0.62f * height, stroke = std::max(1.5f, 0.16f * height);
  float cursor = x;
  while (cursor < x + width - glyph_width) {
    const int letters = dice.integer(2, 8);
    for (int k = 0; k < letters && cursor < x + width - glyph_width; ++k) {
      const float gx = cursor, gy = y;
      switch (dice.integer(0, 5)) {
        case 0:  // vertical bar with a foot
          canvas.rect(gx, gy, gx + stroke, gy + height, ink);
          canvas.rect(gx, gy + height - stroke, gx + glyph_width * 0.8f, gy + height, ink);
          break;
        case 1:  // ring
          canvas.ring(gx + glyph_width * 0.45f, gy + height * 0.6f, glyph_width * 0.45f - stroke, glyph_width * 0.45f,
                      ink);
          break;
        case 2:  // two bars and a cross stroke
          canvas.rect(gx, gy, gx + stroke, gy + height, ink);
          canvas.rect(gx + glyph_width * 0.7f, gy, gx + glyph_width * 0.7f + stroke, gy + height, ink);
          canvas.rect(gx, gy + height * 0.45f, gx + glyph_width * 0.7f, gy + height * 0.45f + stroke, ink);
          break;
        case 3:  // diagonal
          canvas.line(gx, gy + height, gx + glyph_width * 0.8f, gy, stroke, ink);
          break;
        case 4:  // short letter
          canvas.rect(gx, gy + height * 0.4f, gx + glyph_width * 0.8f, gy + height * 0.4f + stroke, ink);
          canvas.rect(gx, gy + height * 0.4f, gx + stroke, gy + height, ink);
          break;
        default:  // block
          canvas.rect(gx, gy + height * 0.35f, gx + glyph_width * 0.7f, gy + height, ink);
          break;
      }
      cursor += glyph_width + stroke;
    }
    cursor += glyph_width * 1.2f;  // space between words
  }
}

}  // namespace panoscan::scenes
