// Relocalization on real renders (not run by ctest): a saved map is imported
// (slam/data/slam_map_import.h), its keyframes get BoW vectors from a vocabulary file, and every
// N-th frame of each dataset is relocalized from scratch (slam/module/relocalizer.h) with ORB
// features as lcv slam extracts them. Per dataset: frames relocalized, time per frame (wall and
// thread CPU, median), inliers, and the accuracy of the relocalized camera centres against the
// dataset's ground truth after a Sim(3) alignment (the map's gauge and scale are arbitrary).
// A dataset of another place measures false relocalizations (expected: none). With --align
// DATASET (the sequence the map was built from), the map is aligned once to that dataset's
// ground truth through its keyframes (matched by timestamp), and every relocalized frame is
// checked against its own ground truth: those off by more than 1 m are counted as wrong (a
// frame outside the mapped area must fail, not return a false pose).
//
//   build/bench/bench_relocalize MAP DATASET... [--every N] [--frames A:B:S] [--vocabulary FILE]
//                                [--align DATASET] [--verbose]
//
// --frames selects the query frames of every DATASET (as lcv slam --frames), --every thins them;
// --verbose prints one line per frame.
//
// Every dataset must have the map's camera (model and size).

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <optional>
#include <string>
#include <vector>

#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/vocabulary_file.h"
#include "slam/data/slam_map_import.h"
#include "slam/feature/orb_extractor.h"
#include "slam/module/relocalizer.h"
#include "slam/solve/umeyama.h"
#include "slam/system.h"

namespace {

using namespace lcv;

double WallMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double CpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> paths;
  int every = 10;
  std::string vocabulary_path = mapping::DefaultVocabularyPath();
  std::string align_path;
  mapping::DatasetOptions query_options;
  bool verbose = false;  // one line per frame
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--every" && i + 1 < argc) {
      every = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--vocabulary" && i + 1 < argc) {
      vocabulary_path = argv[++i];
    } else if (arg == "--align" && i + 1 < argc) {
      align_path = argv[++i];
    } else if (arg == "--verbose") {
      verbose = true;
    } else if (arg == "--frames" && i + 1 < argc) {
      std::string error;
      const auto parsed = mapping::FrameSelection::Parse(argv[++i], &error);
      if (!parsed) {
        std::fprintf(stderr, "--frames: %s\n", error.c_str());
        return 2;
      }
      query_options.frames = *parsed;
    } else {
      paths.push_back(arg);
    }
  }
  if (paths.size() < 2) {
    std::fprintf(stderr,
                 "usage: bench_relocalize MAP DATASET... [--every N] [--frames A:B:S] "
                 "[--vocabulary FILE] [--align DATASET] [--verbose]\n");
    return 2;
  }
  const slam::Map map = mapping::ReadMap(paths[0]);
  const auto vocabulary = mapping::ReadVocabularyFile(vocabulary_path);
  std::unique_ptr<mapping::Dataset> first = mapping::OpenDataset(paths[1]);
  const auto camera = slam::MakeCamera(first->camera());
  const slam::ScaleLevels levels(1.2, 8);
  slam::SlamMap slam_map = slam::ImportSlamMap(map, *camera, levels);
  slam::BowDatabase database;
  for (auto& [id, kf] : slam_map.mutable_keyframes()) {
    vocabulary->Transform(kf.descriptors, &kf.bow.overwrite(), &kf.direct_index.overwrite(),
                          slam::kDirectIndexLevel);
    database.Add(id, kf.bow);
  }
  std::printf("map %s: %zu keyframes, %zu landmarks; vocabulary %s (%zu words)\n",
              paths[0].c_str(), slam_map.keyframes().size(), slam_map.landmarks().size(),
              vocabulary_path.c_str(), vocabulary->num_words());

  // Ground truth from the map's frame: keyframe centres against the aligning dataset's poses.
  std::optional<slam::Sim3d> truth_from_map;
  if (!align_path.empty()) {
    const std::unique_ptr<mapping::Dataset> reference = mapping::OpenDataset(align_path);
    std::vector<Eigen::Vector3d> centres, truth;
    for (const auto& [id, kf] : slam_map.keyframes()) {
      for (const mapping::DatasetFrame& f : reference->frames()) {
        if (std::abs(f.timestamp - kf.timestamp) < 1e-6 && f.world_from_cam) {
          centres.push_back(kf.Center());
          truth.push_back(f.world_from_cam->translation);
        }
      }
    }
    slam::Sim3d sim3;
    if (centres.size() >= 3 && slam::AlignUmeyama(centres, truth, true, &sim3)) {
      truth_from_map = sim3;
      std::printf("aligned to %s through %zu keyframes\n", align_path.c_str(), centres.size());
    }
  }

  slam::OrbExtractorOptions extractor_options;
  extractor_options.num_features = slam::DefaultNumFeatures(camera->model(), camera->cols(), camera->rows());
  if (camera->model() == slam::CameraModel::kEquirectangular) {
    extractor_options.pole_mask_fraction = 0.1f;
  }
  slam::OrbExtractor extractor(extractor_options);
  const slam::RelocalizerOptions options;
  for (std::size_t d = 1; d < paths.size(); ++d) {
    std::unique_ptr<mapping::Dataset> dataset = mapping::OpenDataset(paths[d], query_options);
    int tried = 0, relocalized = 0, wrong = 0;
    std::vector<double> errors;
    std::vector<double> wall_ms, cpu_ms, inliers, candidates;
    std::vector<Eigen::Vector3d> estimated, truth;
    for (std::size_t i = 0; i < dataset->size(); i += every) {
      slam::Frame frame;
      frame.id = i;
      frame.camera = camera.get();
      frame.scale_levels = levels;
      extractor.Extract(dataset->LoadImage(i), cv::Mat(), &frame.keypoints, &frame.descriptors);
      slam::PrepareFrame(&frame);
      const double w0 = WallMs(), c0 = CpuMs();
      const auto result = slam::Relocalize(*vocabulary, database, slam_map, options, i, &frame);
      wall_ms.push_back(WallMs() - w0);
      cpu_ms.push_back(CpuMs() - c0);
      ++tried;
      if (verbose) {
        std::printf("  frame %zu: %s", dataset->frames()[i].index, result ? "" : "failed\n");
        if (result) {
          std::printf("keyframe %llu, %d inliers, candidate %d\n",
                      static_cast<unsigned long long>(result->keyframe_id), result->num_inliers,
                      result->num_candidates_tried);
        }
      }
      if (!result) continue;
      ++relocalized;
      inliers.push_back(result->num_inliers);
      candidates.push_back(result->num_candidates_tried);
      const auto& gt = dataset->frames()[i].world_from_cam;
      if (gt) {
        estimated.push_back(frame.cam_from_world.Center());
        truth.push_back(gt->translation);
        if (truth_from_map) {
          errors.push_back((*truth_from_map * estimated.back() - truth.back()).norm());
          if (errors.back() > 1.0) {
            ++wrong;
            std::printf("  wrong: frame %zu, keyframe %llu, %d inliers, %.2f m off\n",
                        dataset->frames()[i].index,
                        static_cast<unsigned long long>(result->keyframe_id), result->num_inliers,
                        errors.back());
          }
        }
      }
    }
    std::printf("%s: relocalized %d / %d frames (every %d); time median %.1f ms wall, %.1f ms "
                "CPU; relocalized frames: inliers median %.0f, candidates tried median %.0f\n",
                paths[d].c_str(), relocalized, tried, every, Median(wall_ms), Median(cpu_ms),
                Median(inliers), Median(candidates));
    if (truth_from_map && !errors.empty()) {
      std::printf("  against the map's alignment: error median %.3f m, max %.3f m; %d wrong "
                  "(> 1 m)\n",
                  Median(errors), errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end()),
                  wrong);
    }
    slam::Sim3d own_alignment;
    if (estimated.size() >= 3 && slam::AlignUmeyama(estimated, truth, true, &own_alignment)) {
      double sum = 0.0, worst = 0.0;
      for (std::size_t k = 0; k < estimated.size(); ++k) {
        const double e = (own_alignment * estimated[k] - truth[k]).norm();
        sum += e * e;
        worst = std::max(worst, e);
      }
      double extent = 0.0;
      for (const auto& t : truth) extent = std::max(extent, (t - truth.front()).norm());
      std::printf("  centres vs ground truth after Sim(3) alignment: RMSE %.3f m, max %.3f m "
                  "(%zu frames spanning %.1f m)\n",
                  std::sqrt(sum / estimated.size()), worst, estimated.size(), extent);
    }
  }
  return 0;
}
