#pragma once
// Place recognition on the project's synthetic renders, for the tests of the shipped vocabulary:
// a scenario's map sequence fills a BoW database, each client frame queries it, and the ground
// truth poses tell which map frame shows the same place.

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/scene_renderer.h"
#include "render/synth_scenario.h"
#include "slam/bow/bow_database.h"
#include "slam/bow/vocabulary.h"
#include "slam/feature/orb_extractor.h"

namespace lcv::slam::test {

struct RenderedFrame {
  std::vector<OrbDescriptor> descriptors;
  Eigen::Vector3d centre;   // camera centre in the world, m
  Eigen::Vector3d forward;  // optical axis in the world, unit
};

struct RenderedScenario {
  std::vector<RenderedFrame> map, client;
};

// Renders both sequences of a scenario (frames each) with the synthetic camera of `model` and
// extracts num_features ORB features per frame with the SLAM's extractor.
inline RenderedScenario RenderScenario(const std::string& name, int frames, std::uint64_t seed,
                                       CameraModel model, int cols, int rows,
                                       int num_features = 1000) {
  const render::Scenario scenario = render::MakeScenario(name, frames, seed);
  const CameraParams camera = render::SynthCamera(model, cols, rows);
  render::SceneRenderer renderer(scenario.scene);
  OrbExtractorOptions extractor_options;
  extractor_options.num_features = num_features;
  OrbExtractor extractor(extractor_options);
  std::vector<Keypoint> keypoints;
  const auto render_sequence = [&](const std::vector<Rigid3d>& poses, render::SequenceKind kind) {
    std::vector<RenderedFrame> out(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      extractor.Extract(renderer.Render(camera, poses[i], kind), cv::Mat(), &keypoints,
                        &out[i].descriptors);
      const Rigid3d world_from_cam = poses[i].Inverse();
      out[i].centre = world_from_cam.translation;
      out[i].forward = world_from_cam.rotation * Eigen::Vector3d::UnitZ();
    }
    return out;
  };
  RenderedScenario out;
  out.map = render_sequence(scenario.map_cam_from_world, render::SequenceKind::kMap);
  out.client = render_sequence(scenario.client_cam_from_world, render::SequenceKind::kClient);
  return out;
}

// The map frame showing the place of `query`: the nearest camera centre among the map frames
// looking within max_angle_deg of the query's direction; -1 when none is within max_distance_m.
inline int SamePlaceMapFrame(const std::vector<RenderedFrame>& map, const RenderedFrame& query,
                             double max_distance_m, double max_angle_deg = 30.0) {
  const double min_cos = std::cos(max_angle_deg * M_PI / 180.0);
  int best = -1;
  double best_distance = max_distance_m;
  for (std::size_t j = 0; j < map.size(); ++j) {
    if (map[j].forward.dot(query.forward) < min_cos) continue;
    const double distance = (map[j].centre - query.centre).norm();
    if (distance <= best_distance) {
      best_distance = distance;
      best = static_cast<int>(j);
    }
  }
  return best;
}

struct PlaceRecognitionCount {
  int queries = 0;    // client frames with a same-place map frame
  int retrieved = 0;  // ... whose best database match is that frame or an adjacent one
  // Best database score of each client frame with a same-place map frame, and of each client
  // frame farther than unmapped_distance_m from every map camera (a place the map lacks, which
  // loop detection must not mistake for a revisit). In client order.
  std::vector<double> revisit_scores, unmapped_scores;
};

// Map frame j is keyframe id j in the database; client frames without a same-place map frame
// (within max_distance_m) are not counted as queries.
inline PlaceRecognitionCount CountPlaceRecognition(const Vocabulary& vocabulary,
                                                   const RenderedScenario& rendered,
                                                   double max_distance_m,
                                                   double unmapped_distance_m = 10.0) {
  BowDatabase database;
  BowVector bow;
  for (std::size_t j = 0; j < rendered.map.size(); ++j) {
    vocabulary.Transform(rendered.map[j].descriptors, &bow);
    database.Add(static_cast<Id>(j), bow);
  }
  PlaceRecognitionCount count;
  for (const RenderedFrame& query : rendered.client) {
    vocabulary.Transform(query.descriptors, &bow);
    const std::vector<BowQueryResult> best = database.Query(bow, 1);
    const double best_score = best.empty() ? 0.0 : best[0].score;
    const int same_place = SamePlaceMapFrame(rendered.map, query, max_distance_m);
    if (same_place < 0) {
      // 180 degrees: any direction counts as mapped.
      if (SamePlaceMapFrame(rendered.map, query, unmapped_distance_m, 180.0) < 0) {
        count.unmapped_scores.push_back(best_score);
      }
      continue;
    }
    ++count.queries;
    count.revisit_scores.push_back(best_score);
    if (!best.empty() && std::abs(static_cast<int>(best[0].keyframe_id) - same_place) <= 1) {
      ++count.retrieved;
    }
  }
  return count;
}

}  // namespace lcv::slam::test
