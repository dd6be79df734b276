#pragma once
// A textured 3D scene for the synthetic benchmarks: flat textured quads grouped into objects.
//
// World frame: metres, z up (x, y horizontal). A quad is the parallelogram
//   X(a, b) = origin + a * edge_u + b * edge_v,  a, b in [0, 1],
// textured so that texture pixel coordinates (col, row) (continuous, texel i spanning [i, i+1],
// row 0 at the top of the image) land at a = col / cols, b = row / rows. origin is therefore the
// top-left corner of the texture image, and a texel-boundary corner at (col, row) is exactly at
// the 3D point TexturePointToWorld(quad, col, row) -- which is how ground-truth points are placed.
//
// Objects can be concealed per sequence (the `desk` scenario's privacy object is in the map
// sequence only); a quad belongs to exactly one object.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace lcv::render {

struct TexturedQuad {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // world, m: texture top-left corner
  Eigen::Vector3d edge_u = Eigen::Vector3d::UnitX();  // world, m: along texture columns
  Eigen::Vector3d edge_v = -Eigen::Vector3d::UnitZ();  // world, m: along texture rows (down)
  int texture_index = 0;  // into Scene::textures
  int object_id = 0;      // into Scene::objects (by id)
  // Brightness factor in (0, 1], a cheap stand-in for lighting so that faces of a box differ.
  double shade = 1.0;
};

// A ground-truth 3D point: a checker corner drawn into a texture on purpose.
struct GroundTruthPoint {
  int id = 0;
  int object_id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world, m
  // Side of one black square of the marker, m: how large the corner appears at a distance.
  double marker_square_m = 0.0;
  // Unit world directions of the marker's square edges (the quad's texture axes); their cross
  // product (axis_u x axis_v) is the side the texture is seen from, for visibility tests.
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_v = -Eigen::Vector3d::UnitZ();
};

struct SceneObject {
  int id = 0;
  std::string name;  // "facade_12", "desk", "privacy_document"
  std::string kind;  // "facade", "ground", "box", "wall", "privacy"
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();  // world, m; filled by FinalizeScene
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  bool in_map = true;     // present in the map sequence
  bool in_client = true;  // present in the client sequence
};

struct Scene {
  std::vector<cv::Mat> textures;  // CV_8UC3 BGR, any size; power of two not required
  std::vector<TexturedQuad> quads;
  std::vector<SceneObject> objects;
  std::vector<GroundTruthPoint> ground_truth_points;
  // Background (sky, or nothing for a closed room), BGR 0..255.
  cv::Scalar background_bgr = cv::Scalar(235, 206, 135);
};

// World point of the texel-boundary coordinates (col, row) of a quad's texture.
Eigen::Vector3d TexturePointToWorld(const Scene& scene, const TexturedQuad& quad, double col,
                                    double row);

// Recomputes every object's bounding box from its quads. Objects without quads keep theirs.
void FinalizeScene(Scene* scene);

// Which objects a renderer draws: every object present in the given sequence.
enum class SequenceKind { kMap, kClient };
bool ObjectVisibleIn(const SceneObject& object, SequenceKind sequence);

}  // namespace lcv::render
