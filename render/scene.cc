#include "render/scene.h"

#include <limits>

#include "slam/util/error.h"

namespace lcv::render {

Eigen::Vector3d TexturePointToWorld(const Scene& scene, const TexturedQuad& quad, double col,
                                    double row) {
  const cv::Mat& texture = scene.textures.at(quad.texture_index);
  return quad.origin + (col / texture.cols) * quad.edge_u + (row / texture.rows) * quad.edge_v;
}

void FinalizeScene(Scene* scene) {
  for (auto& object : scene->objects) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    bool any = false;
    for (const auto& quad : scene->quads) {
      if (quad.object_id != object.id) continue;
      any = true;
      for (const Eigen::Vector3d& p :
           {quad.origin, Eigen::Vector3d(quad.origin + quad.edge_u),
            Eigen::Vector3d(quad.origin + quad.edge_v),
            Eigen::Vector3d(quad.origin + quad.edge_u + quad.edge_v)}) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    }
    if (any) {
      object.bbox_min = lo;
      object.bbox_max = hi;
    }
  }
}

bool ObjectVisibleIn(const SceneObject& object, SequenceKind sequence) {
  return sequence == SequenceKind::kMap ? object.in_map : object.in_client;
}

}  // namespace lcv::render
