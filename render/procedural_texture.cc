#include "render/procedural_texture.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/util/error.h"

namespace lcv::render {
namespace {

cv::Scalar RandomColor(SplitMix64* rng, int lo = 0, int hi = 255) {
  return cv::Scalar(rng->UniformInt(lo, hi), rng->UniformInt(lo, hi), rng->UniformInt(lo, hi));
}

cv::Scalar Muted(SplitMix64* rng) {
  // Building and wall colours: a base grey with a random tint.
  const int base = rng->UniformInt(90, 200);
  return cv::Scalar(std::clamp(base + rng->UniformInt(-40, 40), 0, 255),
                    std::clamp(base + rng->UniformInt(-40, 40), 0, 255),
                    std::clamp(base + rng->UniformInt(-40, 40), 0, 255));
}

// Contrasting colour: dark on light backgrounds, light on dark ones.
cv::Scalar Contrast(const cv::Scalar& background, SplitMix64* rng) {
  const double luma = 0.114 * background[0] + 0.587 * background[1] + 0.299 * background[2];
  return luma > 128 ? RandomColor(rng, 0, 90) : RandomColor(rng, 170, 255);
}

std::string RandomText(SplitMix64* rng, int length) {
  static const char kAlphabet[] = "ABCDEFGHJKLMNPQRSTUVWXYZ0123456789#&@%+";
  std::string text;
  for (int i = 0; i < length; ++i) text += kAlphabet[rng->UniformInt(0, sizeof(kAlphabet) - 2)];
  return text;
}

// A line of glyphs fitted to a box of height height_px (Hershey fonts: deterministic).
void DrawText(cv::Mat* image, const cv::Point& origin, double height_px, const cv::Scalar& color,
              SplitMix64* rng, int length) {
  if (height_px < 4) return;
  static const int kFonts[] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                               cv::FONT_HERSHEY_COMPLEX, cv::FONT_HERSHEY_TRIPLEX,
                               cv::FONT_HERSHEY_PLAIN};
  const int font = kFonts[rng->UniformInt(0, 4)];
  const double scale = cv::getFontScaleFromHeight(font, static_cast<int>(height_px));
  const int thickness = std::max(1, static_cast<int>(height_px / 12));
  cv::putText(*image, RandomText(rng, length), origin, font, scale, color, thickness,
              cv::LINE_8);
}

void AddGrain(cv::Mat* image, SplitMix64* rng, double sigma) {
  cv::Mat noise(image->size(), CV_16SC3);
  cv::RNG cv_rng(rng->Next());
  cv_rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(sigma));
  cv::Mat sum;
  image->convertTo(sum, CV_16SC3);
  sum += noise;
  sum.convertTo(*image, CV_8UC3);
}

// Random shapes of size around scale_px: rectangles, circles, triangles, strokes, glyphs.
void ScatterShapes(cv::Mat* image, SplitMix64* rng, int count, double scale_px) {
  for (int i = 0; i < count; ++i) {
    const cv::Point c(rng->UniformInt(0, image->cols - 1), rng->UniformInt(0, image->rows - 1));
    const int s = std::max(2, static_cast<int>(scale_px * rng->Uniform(0.4, 1.6)));
    const cv::Scalar color = RandomColor(rng);
    switch (rng->UniformInt(0, 4)) {
      case 0:
        cv::rectangle(*image, c, c + cv::Point(s, rng->UniformInt(s / 2, 2 * s)), color,
                      rng->Uniform() < 0.5 ? -1 : std::max(1, s / 8), cv::LINE_8);
        break;
      case 1:
        cv::circle(*image, c, s / 2, color, rng->Uniform() < 0.5 ? -1 : std::max(1, s / 8),
                   cv::LINE_8);
        break;
      case 2: {
        const cv::Point pts[3] = {c, c + cv::Point(s, rng->UniformInt(-s, s)),
                                  c + cv::Point(rng->UniformInt(-s, s), s)};
        cv::fillConvexPoly(*image, pts, 3, color, cv::LINE_8);
        break;
      }
      case 3:
        cv::line(*image, c, c + cv::Point(rng->UniformInt(-2 * s, 2 * s), rng->UniformInt(-2 * s, 2 * s)),
                 color, std::max(1, s / 6), cv::LINE_8);
        break;
      default:
        DrawText(image, c, s, color, rng, rng->UniformInt(2, 6));
    }
  }
}

void DrawFacade(cv::Mat* image, SplitMix64* rng) {
  const cv::Scalar wall = Muted(rng);
  image->setTo(wall);
  const int cols = image->cols, rows = image->rows;
  // Texel scale: facades are made at ~40 texels per metre (2.5 cm); sizes below assume it.
  if (rng->Uniform() < 0.4) {  // bricks
    const int bh = rng->UniformInt(3, 5), bw = 3 * bh;
    const cv::Scalar mortar = wall * 0.7;
    for (int y = 0, r = 0; y < rows; y += bh, ++r) {
      cv::line(*image, {0, y}, {cols, y}, mortar, 1, cv::LINE_8);
      for (int x = (r % 2) * bw / 2; x < cols; x += bw) cv::line(*image, {x, y}, {x, y + bh}, mortar, 1);
    }
  } else {  // panels
    const int pw = rng->UniformInt(30, 80);
    for (int x = 0; x < cols; x += pw) cv::line(*image, {x, 0}, {x, rows}, wall * 0.8, 1);
  }
  const int storey = rng->UniformInt(110, 140);  // ~3 m
  const int window_w = rng->UniformInt(30, 60), window_h = rng->UniformInt(45, 70);
  const int spacing = window_w + rng->UniformInt(20, 50);
  const cv::Scalar frame = Contrast(wall, rng);
  const int ground_floor = rows - storey;
  for (int top = ground_floor - storey; top + storey > 0; top -= storey) {
    for (int x = rng->UniformInt(10, spacing); x + window_w < cols; x += spacing) {
      const cv::Rect r(x, top + (storey - window_h) / 2, window_w, window_h);
      cv::Scalar glass = RandomColor(rng, 20, 110);
      if (rng->Uniform() < 0.3) glass = RandomColor(rng, 120, 230);  // curtains, lights
      cv::rectangle(*image, r, glass, -1);
      if (rng->Uniform() < 0.6) {  // blinds half-down
        cv::rectangle(*image, cv::Rect(r.x, r.y, r.width, r.height * rng->UniformInt(1, 3) / 4),
                      RandomColor(rng, 150, 255), -1);
      }
      cv::line(*image, {r.x + r.width / 2, r.y}, {r.x + r.width / 2, r.y + r.height}, frame, 2);
      cv::line(*image, {r.x, r.y + r.height / 3}, {r.x + r.width, r.y + r.height / 3}, frame, 2);
      cv::rectangle(*image, r, frame, 3);
      cv::rectangle(*image, cv::Rect(r.x - 4, r.y + r.height, r.width + 8, 5), wall * 0.6, -1);
    }
  }
  // Ground floor: shop fronts with signs, doors, posters.
  for (int x = rng->UniformInt(0, 40); x < cols - 40;) {
    const int w = rng->UniformInt(80, 200);
    const cv::Rect shop(x, ground_floor + 15, std::min(w, cols - x), storey - 15);
    cv::rectangle(*image, shop, RandomColor(rng, 10, 120), -1);
    const cv::Scalar sign = RandomColor(rng);
    const cv::Rect sign_box(shop.x, ground_floor - 10, shop.width, 30);
    cv::rectangle(*image, sign_box, sign, -1);
    DrawText(image, {sign_box.x + 4, sign_box.y + 25}, 20, Contrast(sign, rng), rng,
             std::max(2, shop.width / 22));
    ScatterShapes(image, rng, 6, 18);
    if (rng->Uniform() < 0.7) {
      cv::rectangle(*image, cv::Rect(shop.x + shop.width / 3, shop.y + 20, 36, shop.height - 20),
                    RandomColor(rng, 40, 200), -1);
    }
    x += w + rng->UniformInt(10, 40);
  }
  ScatterShapes(image, rng, cols * rows / 6000, 14);  // graffiti, pipes, vents
  AddGrain(image, rng, 5.0);
}

void DrawGround(cv::Mat* image, SplitMix64* rng) {
  const int g = rng->UniformInt(70, 120);
  image->setTo(cv::Scalar(g, g, g + rng->UniformInt(-5, 5)));
  AddGrain(image, rng, 14.0);
  cv::Mat blurred;
  cv::GaussianBlur(*image, blurred, cv::Size(3, 3), 0.8);
  *image = blurred;
  const int cols = image->cols, rows = image->rows;
  for (int i = 0; i < cols * rows / 4000; ++i) {  // patches and stains
    const cv::Point c(rng->UniformInt(0, cols), rng->UniformInt(0, rows));
    const int v = g + rng->UniformInt(-40, 40);
    if (rng->Uniform() < 0.5) {
      cv::rectangle(*image, c, c + cv::Point(rng->UniformInt(10, 60), rng->UniformInt(10, 60)),
                    cv::Scalar(v, v, v), -1);
    } else {
      cv::ellipse(*image, c, cv::Size(rng->UniformInt(5, 30), rng->UniformInt(5, 30)),
                  rng->Uniform(0, 180), 0, 360, cv::Scalar(v, v, v), -1);
    }
  }
  for (int i = 0; i < cols * rows / 20000 + 2; ++i) {  // cracks
    cv::Point p(rng->UniformInt(0, cols), rng->UniformInt(0, rows));
    for (int k = 0; k < 8; ++k) {
      const cv::Point q = p + cv::Point(rng->UniformInt(-25, 25), rng->UniformInt(-25, 25));
      cv::line(*image, p, q, cv::Scalar::all(g / 3), 1);
      p = q;
    }
  }
  // Painted marks: dashes, arrows, text, manholes.
  const cv::Scalar paint = rng->Uniform() < 0.7 ? cv::Scalar(235, 235, 235) : cv::Scalar(40, 200, 230);
  for (int y = rng->UniformInt(0, 60); y < rows; y += rng->UniformInt(90, 160)) {
    for (int x = 0; x < cols; x += 120) cv::rectangle(*image, cv::Rect(x, y, 60, 6), paint, -1);
  }
  for (int i = 0; i < std::max(2, cols * rows / 30000); ++i) {
    const cv::Point c(rng->UniformInt(20, std::max(21, cols - 60)), rng->UniformInt(40, std::max(41, rows - 20)));
    if (rng->Uniform() < 0.5) {
      DrawText(image, c, rng->UniformInt(16, 40), paint, rng, rng->UniformInt(2, 4));
    } else {
      cv::circle(*image, c, 14, cv::Scalar::all(40), -1);
      cv::circle(*image, c, 14, cv::Scalar::all(150), 2);
      cv::line(*image, c - cv::Point(10, 0), c + cv::Point(10, 0), cv::Scalar::all(150), 1);
    }
  }
}

void DrawPosters(cv::Mat* image, SplitMix64* rng, int count, int min_size, int max_size) {
  for (int i = 0; i < count; ++i) {
    const int w = rng->UniformInt(min_size, max_size), h = rng->UniformInt(min_size, max_size);
    const cv::Rect r(rng->UniformInt(0, std::max(0, image->cols - w)),
                     rng->UniformInt(0, std::max(0, image->rows - h)), w, h);
    const cv::Scalar paper = RandomColor(rng, 60, 255);
    cv::rectangle(*image, r, paper, -1);
    cv::Mat roi = (*image)(r & cv::Rect(0, 0, image->cols, image->rows));
    ScatterShapes(&roi, rng, 8 + w * h / 900, std::max(4, std::min(w, h) / 6));
    for (int y = h / 5; y < h - 4; y += std::max(8, h / 8)) {
      DrawText(&roi, {4, y}, std::max(5, h / 14), Contrast(paper, rng), rng, std::max(2, w / 12));
    }
    cv::rectangle(*image, r, RandomColor(rng, 0, 80), std::max(2, w / 40));
  }
}

void DrawWall(cv::Mat* image, SplitMix64* rng) {
  image->setTo(Muted(rng) * 0.5 + cv::Scalar::all(110));
  AddGrain(image, rng, 3.0);
  const int cols = image->cols, rows = image->rows;
  DrawPosters(image, rng, std::max(3, cols * rows / 40000), 60, 220);
  for (int i = 0; i < cols / 400 + 1; ++i) {  // shelves with books
    const int y = rng->UniformInt(rows / 5, rows * 3 / 4);
    const int x0 = rng->UniformInt(0, std::max(1, cols - 300));
    cv::rectangle(*image, cv::Rect(x0, y, 260, 10), cv::Scalar(40, 70, 110), -1);
    for (int x = x0 + 4; x < x0 + 250; x += rng->UniformInt(8, 18)) {
      const int h = rng->UniformInt(30, 60);
      cv::rectangle(*image, cv::Rect(x, y - h, rng->UniformInt(6, 14), h), RandomColor(rng), -1);
    }
  }
  cv::rectangle(*image, cv::Rect(0, rows - 24, cols, 24), cv::Scalar::all(60), -1);  // skirting
}

void DrawFloor(cv::Mat* image, SplitMix64* rng) {
  const cv::Scalar base(rng->UniformInt(40, 90), rng->UniformInt(80, 130), rng->UniformInt(120, 180));
  image->setTo(base);
  AddGrain(image, rng, 10.0);
  const int plank = rng->UniformInt(30, 45);
  for (int y = 0, r = 0; y < image->rows; y += plank, ++r) {
    cv::line(*image, {0, y}, {image->cols, y}, base * 0.5, 2);
    for (int x = rng->UniformInt(0, 200); x < image->cols; x += rng->UniformInt(150, 300)) {
      cv::line(*image, {x, y}, {x, y + plank}, base * 0.5, 2);
    }
  }
  ScatterShapes(image, rng, image->cols * image->rows / 12000, 18);  // rugs, cables, stains
}

void DrawWood(cv::Mat* image, SplitMix64* rng) {
  const cv::Scalar base(rng->UniformInt(50, 80), rng->UniformInt(100, 130), rng->UniformInt(150, 190));
  image->setTo(base);
  for (int y = 0; y < image->rows; y += 3) {  // grain
    const int v = rng->UniformInt(-25, 25);
    cv::line(*image, {0, y}, {image->cols, y + rng->UniformInt(-3, 3)}, base + cv::Scalar::all(v), 1);
  }
  AddGrain(image, rng, 6.0);
  DrawPosters(image, rng, std::max(2, image->cols * image->rows / 30000), 40, 120);  // papers
  ScatterShapes(image, rng, image->cols * image->rows / 3000, 10);  // pens, notes, crumbs
}

void DrawObject(cv::Mat* image, SplitMix64* rng) {
  const cv::Scalar base = RandomColor(rng, 30, 230);
  image->setTo(base);
  ScatterShapes(image, rng, std::max(6, image->cols * image->rows / 400), std::max(4, image->cols / 8));
  DrawText(image, {4, image->rows / 2}, std::max(6, image->rows / 6), Contrast(base, rng), rng, 5);
  AddGrain(image, rng, 4.0);
}

void DrawPrivacy(cv::Mat* image, SplitMix64* rng) {
  image->setTo(cv::Scalar(245, 245, 250));
  const int cols = image->cols, rows = image->rows;
  // A "photo" block, a letterhead, text lines and a signature.
  const cv::Rect photo(cols / 12, rows / 10, cols / 3, rows / 3);
  cv::rectangle(*image, photo, RandomColor(rng, 60, 200), -1);
  cv::Mat roi = (*image)(photo);
  ScatterShapes(&roi, rng, 40, photo.width / 5.0);
  cv::rectangle(*image, photo, cv::Scalar::all(20), 2);
  DrawText(image, {cols / 2, rows / 6}, rows / 14.0, cv::Scalar(120, 20, 20), rng, 6);
  for (int y = rows / 2; y < rows * 9 / 10; y += std::max(8, rows / 16)) {
    DrawText(image, {cols / 12, y}, rows / 26.0, cv::Scalar::all(30), rng, std::max(3, cols / 16));
  }
  cv::Point p(cols * 2 / 3, rows * 9 / 10);
  for (int k = 0; k < 10; ++k) {
    const cv::Point q = p + cv::Point(rng->UniformInt(4, 14), rng->UniformInt(-10, 10));
    cv::line(*image, p, q, cv::Scalar(140, 30, 10), 2);
    p = q;
  }
}

}  // namespace

cv::Mat MakeTexture(TextureStyle style, int cols, int rows, std::uint64_t seed) {
  LCV_CHECK(cols >= 8 && rows >= 8) << cols << "x" << rows;
  cv::Mat image(rows, cols, CV_8UC3);
  SplitMix64 rng(seed ^ 0x7E57u);
  switch (style) {
    case TextureStyle::kFacade: DrawFacade(&image, &rng); break;
    case TextureStyle::kGround: DrawGround(&image, &rng); break;
    case TextureStyle::kWall: DrawWall(&image, &rng); break;
    case TextureStyle::kFloor: DrawFloor(&image, &rng); break;
    case TextureStyle::kWood: DrawWood(&image, &rng); break;
    case TextureStyle::kObject: DrawObject(&image, &rng); break;
    case TextureStyle::kPrivacy: DrawPrivacy(&image, &rng); break;
  }
  return image;
}

void DrawCheckerMarker(cv::Mat* texture, int col, int row, int half_size) {
  const int h = half_size, frame = std::max(1, half_size / 2);
  cv::rectangle(*texture, cv::Rect(col - h - frame, row - h - frame, 2 * (h + frame), 2 * (h + frame)),
                cv::Scalar::all(255), -1);
  cv::rectangle(*texture, cv::Rect(col - h, row - h, h, h), cv::Scalar::all(0), -1);
  cv::rectangle(*texture, cv::Rect(col, row, h, h), cv::Scalar::all(0), -1);
}

std::vector<Eigen::Vector2i> PlaceCheckerMarkers(cv::Mat* texture, int count, int half_size,
                                                 SplitMix64* rng) {
  std::vector<Eigen::Vector2i> placed;
  const int extent = half_size + std::max(1, half_size / 2);  // centre to frame edge
  const int lo = 2 * half_size;
  const int max_i = (texture->cols - lo - extent) / half_size;
  const int max_j = (texture->rows - lo - extent) / half_size;
  const int min_i = (lo + extent + half_size - 1) / half_size;
  const int min_j = min_i;
  if (max_i < min_i || max_j < min_j) return placed;
  for (int attempt = 0; attempt < 50 * count && static_cast<int>(placed.size()) < count; ++attempt) {
    const Eigen::Vector2i c(rng->UniformInt(min_i, max_i) * half_size,
                            rng->UniformInt(min_j, max_j) * half_size);
    bool free = true;
    for (const auto& p : placed) free &= (p - c).cwiseAbs().maxCoeff() >= 2 * extent + half_size;
    if (!free) continue;
    DrawCheckerMarker(texture, c.x(), c.y(), half_size);
    placed.push_back(c);
  }
  return placed;
}

}  // namespace lcv::render
