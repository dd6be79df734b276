#include "render/synth_scenario.h"

#include <algorithm>
#include <cmath>

#include "render/procedural_texture.h"
#include "slam/util/error.h"

namespace lcv::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

double Deg(double degrees) { return degrees * kPi / 180.0; }

// Camera looking along `forward` (world), level (no roll): x right, y down, z forward.
slam::Rigid3d LookAlong(const Eigen::Vector3d& position, const Eigen::Vector3d& forward) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = z.cross(kUp).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  Eigen::Quaterniond q(world_from_cam);
  q.normalize();
  return slam::Rigid3d(q, position).Inverse();
}

Eigen::Vector3d Heading(double yaw, double pitch_down) {
  return {std::cos(yaw) * std::cos(pitch_down), std::sin(yaw) * std::cos(pitch_down),
          -std::sin(pitch_down)};
}

// A ground path sampled densely; At(s) by arc length, wrapping around when closed.
class Path {
 public:
  Path(const std::vector<Eigen::Vector2d>& points, bool closed) : closed_(closed) {
    points_ = points;
    if (closed) points_.push_back(points.front());
    arc_.assign(points_.size(), 0.0);
    for (size_t i = 1; i < points_.size(); ++i) {
      arc_[i] = arc_[i - 1] + (points_[i] - points_[i - 1]).norm();
    }
  }
  double length() const { return arc_.back(); }
  Eigen::Vector2d At(double s) const {
    if (closed_) {
      s = std::fmod(s, length());
      if (s < 0) s += length();
    }
    s = std::clamp(s, 0.0, length());
    const size_t i = std::min<size_t>(
        std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin(), arc_.size() - 1);
    const size_t i0 = i == 0 ? 0 : i - 1;
    const double span = arc_[i] - arc_[i0];
    const double a = span > 0 ? (s - arc_[i0]) / span : 0.0;
    return points_[i0] + a * (points_[i] - points_[i0]);
  }
  // Smoothed heading angle at s (difference over +-1.5 m).
  double Yaw(double s) const {
    const Eigen::Vector2d d = At(s + 1.5) - At(s - 1.5);
    return std::atan2(d.y(), d.x());
  }

 private:
  bool closed_;
  std::vector<Eigen::Vector2d> points_;
  std::vector<double> arc_;
};

// Counter-clockwise rectangle [x0, x1] x [y0, y1] with corners rounded to radius r, starting at
// the middle of the bottom side.
Path RoundedRectangle(double x0, double x1, double y0, double y1, double r) {
  std::vector<Eigen::Vector2d> pts;
  const Eigen::Vector2d centres[4] = {{x1 - r, y0 + r}, {x1 - r, y1 - r}, {x0 + r, y1 - r},
                                      {x0 + r, y0 + r}};
  pts.emplace_back(0.5 * (x0 + x1), y0);
  for (int c = 0; c < 4; ++c) {
    const double start = -kPi / 2 + c * kPi / 2;
    for (int k = 0; k <= 12; ++k) {
      const double a = start + (kPi / 2) * k / 12.0;
      pts.push_back(centres[c] + r * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
  }
  return Path(pts, true);
}

class SceneBuilder {
 public:
  SceneBuilder(Scene* scene, std::uint64_t seed) : scene_(scene), rng_(seed) {}
  SplitMix64& rng() { return rng_; }

  int AddObject(const std::string& name, const std::string& kind) {
    SceneObject object;
    object.id = static_cast<int>(scene_->objects.size());
    object.name = name;
    object.kind = kind;
    scene_->objects.push_back(object);
    return object.id;
  }

  // A quad with its own texture at texels_per_m, `markers` checker markers as ground truth.
  void AddQuad(int object_id, const Eigen::Vector3d& origin, const Eigen::Vector3d& edge_u,
               const Eigen::Vector3d& edge_v, TextureStyle style, double texels_per_m,
               int markers, int marker_half_texels = 8, double shade = 1.0) {
    // Multiples of 32 texels: mip levels 1..5 then halve exactly, so a texel boundary of the
    // base level stays a boundary and markers do not drift with distance (an odd level size
    // stretches everything above it by up to a texel of that level).
    const auto texels = [&](double length_m) {
      const long n = std::lround(length_m * texels_per_m / 32.0);
      return static_cast<int>(std::clamp(n, 1L, 64L)) * 32;
    };
    const int cols = texels(edge_u.norm()), rows = texels(edge_v.norm());
    cv::Mat texture = MakeTexture(style, cols, rows, rng_.Next());
    TexturedQuad quad;
    quad.origin = origin;
    quad.edge_u = edge_u;
    quad.edge_v = edge_v;
    quad.texture_index = static_cast<int>(scene_->textures.size());
    quad.object_id = object_id;
    quad.shade = shade;
    const auto corners = PlaceCheckerMarkers(&texture, markers, marker_half_texels, &rng_);
    scene_->textures.push_back(texture);
    scene_->quads.push_back(quad);
    for (const auto& c : corners) {
      GroundTruthPoint point;
      point.id = static_cast<int>(scene_->ground_truth_points.size());
      point.object_id = object_id;
      point.position = TexturePointToWorld(*scene_, quad, c.x(), c.y());
      point.marker_square_m = marker_half_texels * edge_u.norm() / cols;
      point.axis_u = edge_u.normalized();
      point.axis_v = edge_v.normalized();
      scene_->ground_truth_points.push_back(point);
    }
  }

  // An upright box standing on z = base.z(), centred at base in x, y, rotated by yaw about z:
  // four textured sides and a textured top.
  void AddBox(int object_id, const Eigen::Vector3d& base, const Eigen::Vector3d& size, double yaw,
              TextureStyle style, double texels_per_m, int markers_per_face,
              int marker_half_texels = 8) {
    const Eigen::Vector3d ex(std::cos(yaw), std::sin(yaw), 0), ey(-std::sin(yaw), std::cos(yaw), 0);
    const Eigen::Vector3d hx = 0.5 * size.x() * ex, hy = 0.5 * size.y() * ey;
    const Eigen::Vector3d top = base + size.z() * kUp;
    const Eigen::Vector3d down = -size.z() * kUp;
    // Sides seen from outside, texture upright: origin top-left, u to the viewer's right.
    const double shades[4] = {1.0, 0.85, 0.7, 0.9};
    const Eigen::Vector3d side_origin[4] = {top - hy - hx, top - hy + hx, top + hy + hx,
                                            top + hy - hx};
    const Eigen::Vector3d side_u[4] = {2 * hx, 2 * hy, -2 * hx, -2 * hy};
    for (int k = 0; k < 4; ++k) {
      AddQuad(object_id, side_origin[k], side_u[k], down, style, texels_per_m, markers_per_face,
              marker_half_texels, shades[k]);
    }
    AddQuad(object_id, top + hy - hx, 2 * hx, -2 * hy, style, texels_per_m, markers_per_face,
            marker_half_texels, 0.95);
  }

  // Buildings along the segment a -> b, their fronts facing `toward` (horizontal unit vector
  // pointing from the facades into the street). Widths and heights drawn at random.
  void AddFacadeRow(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                    const Eigen::Vector3d& toward, double min_height, double max_height) {
    // Seen from the street the viewer's right is (-toward) x up; walk the row in that direction.
    const Eigen::Vector3d right = (-toward).cross(kUp).normalized();
    Eigen::Vector3d start = a, end = b;
    if ((b - a).dot(right) < 0) std::swap(start, end);
    const double length = (end - start).norm();
    for (double s = 0; s < length - 1e-6;) {
      double width = rng_.Uniform(8.0, 16.0);
      if (length - (s + width) < 6.0) width = length - s;  // no sliver at the end
      const double height = rng_.Uniform(min_height, max_height);
      const int object = AddObject("facade_" + std::to_string(scene_->objects.size()), "facade");
      const Eigen::Vector3d left_bottom = start + s * right;
      AddQuad(object, left_bottom + height * kUp, width * right, -height * kUp,
              TextureStyle::kFacade, 40.0, 4, 16, rng_.Uniform(0.8, 1.0));
      s += width;
    }
  }

  // Ground tiles over [x0, x1] x [y0, y1] (z = 0), skipping tiles inside `hole` (if non-empty).
  void AddGround(double x0, double x1, double y0, double y1, double tile_m,
                 const Eigen::Vector4d& hole = Eigen::Vector4d::Zero()) {
    for (double x = x0; x < x1 - 1e-6; x += tile_m) {
      for (double y = y0; y < y1 - 1e-6; y += tile_m) {
        const double w = std::min(tile_m, x1 - x), h = std::min(tile_m, y1 - y);
        if (x >= hole[0] && x + w <= hole[1] && y >= hole[2] && y + h <= hole[3]) continue;
        const int object = AddObject("ground_" + std::to_string(scene_->objects.size()), "ground");
        AddQuad(object, Eigen::Vector3d(x, y + h, 0), Eigen::Vector3d(w, 0, 0),
                Eigen::Vector3d(0, -h, 0), TextureStyle::kGround, 40.0, 2, 16);
      }
    }
  }

 private:
  Scene* scene_;
  SplitMix64 rng_;
};

std::vector<double> Samples(double s0, double s1, int frames) {
  std::vector<double> s(frames);
  for (int i = 0; i < frames; ++i) s[i] = frames == 1 ? s0 : s0 + (s1 - s0) * i / (frames - 1.0);
  return s;
}

// Street scenarios: a straight street along +x, x in [0, 100], facades at y = +-7.
void BuildStreet(Scenario* scenario, int frames) {
  SceneBuilder builder(&scenario->scene, scenario->seed);
  const double half_width = 7.0, x0 = -10.0, x1 = 110.0;
  builder.AddGround(x0, x1, -half_width, half_width, 10.0);
  builder.AddFacadeRow({x0, half_width, 0}, {x1, half_width, 0}, -Eigen::Vector3d::UnitY(), 7, 16);
  builder.AddFacadeRow({x0, -half_width, 0}, {x1, -half_width, 0}, Eigen::Vector3d::UnitY(), 7, 16);
  builder.AddFacadeRow({x1, -half_width, 0}, {x1, half_width, 0}, -Eigen::Vector3d::UnitX(), 12, 16);
  builder.AddFacadeRow({x0, -half_width, 0}, {x0, half_width, 0}, Eigen::Vector3d::UnitX(), 12, 16);
  // Parked cars and kiosks on both sides: parallax and corners at several depths.
  for (double x = 4.0; x < 100.0; x += builder.rng().Uniform(7.0, 15.0)) {
    const double side = builder.rng().Uniform() < 0.5 ? -1.0 : 1.0;
    const int object = builder.AddObject("box_" + std::to_string(scenario->scene.objects.size()), "box");
    builder.AddBox(object, {x, side * (half_width - 1.6), 0},
                   {builder.rng().Uniform(1.5, 4.0), builder.rng().Uniform(1.2, 1.8),
                    builder.rng().Uniform(1.2, 2.2)},
                   builder.rng().Uniform(-0.1, 0.1), TextureStyle::kObject, 60.0, 1, 8);
  }
  const bool overlap = scenario->name == "overlap";
  const Path street({{0.0, 0.0}, {100.0, 0.0}}, false);
  const auto pose = [&](double x, double lateral, double height, double yaw, double pitch) {
    return LookAlong(Eigen::Vector3d(x, lateral, height), Heading(street.Yaw(x) + yaw, pitch));
  };
  const std::vector<double> map_s = overlap ? Samples(5.0, 62.0, frames) : Samples(5.0, 95.0, frames);
  const std::vector<double> client_s = overlap ? Samples(38.0, 95.0, frames) : Samples(6.0, 94.0, frames);
  // A gentle weave (as a driver's): also keeps the camera centres off one straight line, which
  // would make a Sim(3) alignment of an estimate to the ground truth degenerate.
  for (double x : map_s) {
    const double phase = 2 * kPi * x / 29.0;
    scenario->map_cam_from_world.push_back(
        pose(x, -2.0 + 0.25 * std::sin(phase), 1.6, std::atan(0.25 * 2 * kPi / 29.0 * std::cos(phase)), Deg(2)));
  }
  for (double x : client_s) {
    const double wobble = std::sin(2 * kPi * x / 17.0);
    scenario->client_cam_from_world.push_back(
        pose(x, -1.6 + 0.15 * wobble, 1.5, Deg(3) * wobble, Deg(3)));
  }
}

// Loop scenario: a block [-30, 30] x [-20, 20] with a 12 m ring street around it.
void BuildLoop(Scenario* scenario, int frames) {
  SceneBuilder builder(&scenario->scene, scenario->seed);
  const double ix = 30, iy = 20, ox = 42, oy = 32;
  builder.AddGround(-ox, ox, -oy, oy, 12.0, Eigen::Vector4d(-ix, ix, -iy, iy));
  // Inner block, facing out.
  builder.AddFacadeRow({-ix, -iy, 0}, {ix, -iy, 0}, -Eigen::Vector3d::UnitY(), 8, 18);
  builder.AddFacadeRow({ix, -iy, 0}, {ix, iy, 0}, Eigen::Vector3d::UnitX(), 8, 18);
  builder.AddFacadeRow({ix, iy, 0}, {-ix, iy, 0}, Eigen::Vector3d::UnitY(), 8, 18);
  builder.AddFacadeRow({-ix, iy, 0}, {-ix, -iy, 0}, -Eigen::Vector3d::UnitX(), 8, 18);
  // Outer ring, facing in.
  builder.AddFacadeRow({-ox, -oy, 0}, {ox, -oy, 0}, Eigen::Vector3d::UnitY(), 8, 18);
  builder.AddFacadeRow({ox, -oy, 0}, {ox, oy, 0}, -Eigen::Vector3d::UnitX(), 8, 18);
  builder.AddFacadeRow({ox, oy, 0}, {-ox, oy, 0}, -Eigen::Vector3d::UnitY(), 8, 18);
  builder.AddFacadeRow({-ox, oy, 0}, {-ox, -oy, 0}, Eigen::Vector3d::UnitX(), 8, 18);
  const Path ring = RoundedRectangle(-36, 36, -26, 26, 5.0);
  const double length = ring.length();
  const auto pose = [&](double s, double lateral, double height, double yaw, double pitch) {
    const double heading = ring.Yaw(s);
    const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
    const Eigen::Vector2d p = ring.At(s) + lateral * left;
    return LookAlong(Eigen::Vector3d(p.x(), p.y(), height), Heading(heading + yaw, pitch));
  };
  for (double s : Samples(0.0, 0.55 * length, frames)) {
    scenario->map_cam_from_world.push_back(pose(s, -1.0, 1.6, 0.0, Deg(2)));
  }
  for (double s : Samples(0.05 * length, 1.15 * length, frames)) {
    const double wobble = std::sin(2 * kPi * s / 23.0);
    scenario->client_cam_from_world.push_back(pose(s, -0.6 + 0.2 * wobble, 1.5, Deg(2) * wobble, Deg(3)));
  }
}

// Desk scenario: a 6 x 5 x 2.8 m room, a desk in the middle, objects on it.
void BuildDesk(Scenario* scenario, int frames) {
  Scene& scene = scenario->scene;
  SceneBuilder builder(&scene, scenario->seed);
  scene.background_bgr = cv::Scalar(40, 40, 40);
  const double rx = 3.0, ry = 2.5, rz = 2.8;
  const int room = builder.AddObject("room", "wall");
  // Walls seen from inside, upright.
  builder.AddQuad(room, {-rx, ry, rz}, {2 * rx, 0, 0}, {0, 0, -rz}, TextureStyle::kWall, 150, 6, 16);
  builder.AddQuad(room, {rx, -ry, rz}, {-2 * rx, 0, 0}, {0, 0, -rz}, TextureStyle::kWall, 150, 6, 16);
  builder.AddQuad(room, {rx, ry, rz}, {0, -2 * ry, 0}, {0, 0, -rz}, TextureStyle::kWall, 150, 6, 16);
  builder.AddQuad(room, {-rx, -ry, rz}, {0, 2 * ry, 0}, {0, 0, -rz}, TextureStyle::kWall, 150, 6, 16);
  builder.AddQuad(room, {-rx, ry, 0}, {2 * rx, 0, 0}, {0, -2 * ry, 0}, TextureStyle::kFloor, 150, 6, 16);
  builder.AddQuad(room, {-rx, -ry, rz}, {2 * rx, 0, 0}, {0, 2 * ry, 0}, TextureStyle::kWall, 80, 2,
                  8, 0.8);
  const Eigen::Vector3d desk_centre(0.0, 0.5, 0.0);
  const double desk_height = 0.75;
  const int desk = builder.AddObject("desk", "desk");
  builder.AddBox(desk, desk_centre, {1.6, 0.8, desk_height}, 0.0, TextureStyle::kWood, 300, 2, 16);
  const Eigen::Vector3d on_desk = desk_centre + desk_height * kUp;
  const int monitor = builder.AddObject("monitor", "box");
  builder.AddBox(monitor, on_desk + Eigen::Vector3d(-0.35, 0.2, 0), {0.6, 0.06, 0.4}, 0.0,
                 TextureStyle::kObject, 400, 1, 16);
  const int books = builder.AddObject("books", "box");
  builder.AddBox(books, on_desk + Eigen::Vector3d(0.5, 0.15, 0), {0.25, 0.3, 0.12}, 0.3,
                 TextureStyle::kObject, 400, 1, 16);
  const int mug = builder.AddObject("mug", "box");
  builder.AddBox(mug, on_desk + Eigen::Vector3d(0.45, -0.2, 0), {0.09, 0.09, 0.11}, -0.5,
                 TextureStyle::kObject, 500, 0);
  // The privacy object: a document in a stand, facing the camera side (-y).
  const int privacy = builder.AddObject("privacy_document", "privacy");
  scene.objects[privacy].in_client = false;
  builder.AddBox(privacy, on_desk + Eigen::Vector3d(0.05, -0.1, 0), {0.3, 0.03, 0.22}, 0.0,
                 TextureStyle::kPrivacy, 800, 2, 16);
  const Eigen::Vector3d target = on_desk + Eigen::Vector3d(0, 0.1, 0.05);
  const auto pose = [&](double azimuth, double radius, double height) {
    const Eigen::Vector3d position =
        target + Eigen::Vector3d(radius * std::cos(azimuth), radius * std::sin(azimuth), 0) +
        (height - target.z()) * kUp;
    return LookAlong(position, target - position);
  };
  for (double a : Samples(Deg(-150), Deg(-30), frames)) {
    scenario->map_cam_from_world.push_back(pose(a, 1.8, 1.45));
  }
  for (double a : Samples(Deg(-140), Deg(-40), frames)) {
    scenario->client_cam_from_world.push_back(pose(a, 1.7 + 0.1 * std::sin(3 * a), 1.5));
  }
}

}  // namespace

const std::vector<std::string>& ScenarioNames() {
  static const std::vector<std::string> names = {"tracking", "overlap", "loop", "desk"};
  return names;
}

Scenario MakeScenario(const std::string& name, int frames, std::uint64_t seed) {
  LCV_CHECK(frames >= 1) << frames;
  Scenario scenario;
  scenario.name = name;
  scenario.seed = seed;
  if (name == "tracking" || name == "overlap") {
    BuildStreet(&scenario, frames);
  } else if (name == "loop") {
    BuildLoop(&scenario, frames);
  } else if (name == "desk") {
    BuildDesk(&scenario, frames);
    scenario.fps = 15.0;
  } else {
    LCV_CHECK(false) << "unknown scenario '" << name << "'";
  }
  FinalizeScene(&scenario.scene);
  return scenario;
}

slam::CameraParams SynthCamera(slam::CameraModel model, int cols, int rows, double fps) {
  slam::CameraParams camera;
  camera.name = std::string("synth_") + slam::CameraModelName(model);
  camera.model = model;
  camera.cols = cols;
  camera.rows = rows;
  camera.fps = fps;
  camera.cx = 0.5 * (cols - 1);
  camera.cy = 0.5 * (rows - 1);
  switch (model) {
    case slam::CameraModel::kPerspective:
      camera.fx = camera.fy = 0.5 * cols / std::tan(Deg(40));
      break;
    case slam::CameraModel::kFisheye: {
      camera.distortion = {0.02, -0.004, 0.0005, 0.0, 0.0};
      const double theta = Deg(95);
      const double t2 = theta * theta;
      const double theta_d = theta * (1 + t2 * (0.02 + t2 * (-0.004 + t2 * 0.0005)));
      camera.fx = camera.fy = 0.5 * cols / theta_d;
      break;
    }
    case slam::CameraModel::kEquirectangular:
      break;
  }
  return camera;
}

}  // namespace lcv::render
