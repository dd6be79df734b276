// Integration: relocalization after an interruption and map reuse (save, load, localize) on
// synthetic feature sequences with known ground truth, the engine in deterministic mode. The
// vocabulary is trained in the test on the scene's own descriptors (a small tree: the point is
// the engine's use of it, the shipped vocabulary is tested in tests/slam/bow).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/trajectory.h"
#include "slam/bow/vocabulary.h"
#include "slam/solve/umeyama.h"
#include "slam/system.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

std::shared_ptr<const Vocabulary> TrainVocabulary(const testing::SyntheticScene& scene) {
  // One "image" per block of 100 points, so that the idf weights are informative.
  std::vector<std::vector<OrbDescriptor>> images;
  for (size_t i = 0; i < scene.descriptors.size(); i += 100) {
    const size_t end = std::min(scene.descriptors.size(), i + 100);
    images.emplace_back(scene.descriptors.begin() + i, scene.descriptors.begin() + end);
  }
  VocabularyOptions options;
  options.branching = 8;
  options.depth = 3;
  return std::make_shared<const Vocabulary>(Vocabulary::Train(images, options));
}

struct Sequence {
  std::vector<Rigid3d> truth;
  std::vector<testing::SyntheticFrame> frames;
};

// Frames of the lateral trajectory (0.1 m per frame), shifted by `offset` in the world.
Sequence MakeSequence(const testing::SyntheticScene& scene, const Camera& camera, int num_frames,
                      const Eigen::Vector3d& offset, std::uint64_t seed) {
  Sequence sequence;
  std::mt19937_64 rng(seed);
  for (const Rigid3d& cam_from_world : testing::MakeLateralTrajectory(num_frames, 0.1)) {
    const Rigid3d shifted(cam_from_world.rotation,
                          cam_from_world.translation - cam_from_world.rotation * offset);
    sequence.truth.push_back(shifted);
    sequence.frames.push_back(
        testing::ObserveScene(scene, camera, shifted, testing::ObservationNoise(), &rng));
  }
  return sequence;
}

struct RunResult {
  std::vector<FrameResult> results;
  std::vector<TimedPose> trajectory;
  mapping::TrajectoryErrorReport ape;
  SystemStats stats;
  int keyframes = 0;
  int initializations = 0;
  Map map;
};

// blank: frames [blank_begin, blank_end) carry no features (a covered lens).
RunResult RunSequence(System* system, const Sequence& sequence, int blank_begin = -1,
              int blank_end = -1) {
  RunResult run;
  mapping::Trajectory gt;
  for (size_t i = 0; i < sequence.frames.size(); ++i) {
    const double timestamp = 0.1 * static_cast<double>(i);
    testing::SyntheticFrame frame = sequence.frames[i];
    if (static_cast<int>(i) >= blank_begin && static_cast<int>(i) < blank_end) {
      frame.keypoints.clear();
      frame.descriptors.clear();
    }
    run.results.push_back(
        system->TrackFeatures(std::move(frame.keypoints), std::move(frame.descriptors), timestamp));
    gt.poses.push_back({timestamp, sequence.truth[i]});
    if (std::getenv("LCV_TEST_VERBOSE")) {
      const FrameResult& r = run.results.back();
      std::fprintf(stderr, "frame %zu: %s, %d matches%s%s\n", i, TrackingStateName(r.state),
                   r.num_matches, r.is_keyframe ? ", keyframe" : "",
                   r.relocalized ? ", relocalized" : "");
    }
  }
  system->Finish();
  run.trajectory = system->FrameTrajectory();
  run.stats = system->Stats();
  run.keyframes = system->NumKeyframes();
  run.initializations = system->NumInitializations();
  run.map = system->ExportMap();
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  run.ape = mapping::ComputeApe(gt, mapping::MakeTrajectory(run.trajectory), ape_options);
  return run;
}

class RelocalizationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    params_ = testing::SyntheticPinhole();
    camera_ = MakeCamera(params_);
    scene_ = testing::MakeSlabScene(4000, -4.0, 13.0, 4.0, 9.0, 11);
    vocabulary_ = TrainVocabulary(scene_);
  }
  SystemOptions Options(bool with_vocabulary) const {
    SystemOptions options;
    options.deterministic = true;
    options.seed = 5;
    if (with_vocabulary) options.vocabulary = vocabulary_;
    return options;
  }

  // Frames 0-59 of the street, then the views of frames 20-49 again (the camera carried back).
  Sequence Kidnapped() const {
    const Sequence original = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d::Zero(), 13);
    Sequence sequence = original;
    for (int i = 20; i < 50; ++i) {
      sequence.truth.push_back(original.truth[i]);
      sequence.frames.push_back(original.frames[i]);
    }
    return sequence;
  }

  CameraParams params_;
  std::unique_ptr<Camera> camera_;
  testing::SyntheticScene scene_;
  std::shared_ptr<const Vocabulary> vocabulary_;
};

TEST_F(RelocalizationTest, ResumesWithinTenFramesOfAnInterruption) {
  const Sequence sequence = MakeSequence(scene_, *camera_, 90, Eigen::Vector3d::Zero(), 12);
  constexpr int kBlankBegin = 50, kBlankEnd = 60;  // one second at 10 Hz
  System system(params_, Options(true));
  const RunResult run = RunSequence(&system, sequence, kBlankBegin, kBlankEnd);

  int resumed = -1;
  for (int i = kBlankEnd; i < static_cast<int>(run.results.size()); ++i) {
    if (run.results[i].state == TrackingState::kTracking) {
      resumed = i;
      break;
    }
  }
  ASSERT_GE(resumed, kBlankEnd) << "tracking never resumed";
  EXPECT_LT(resumed - kBlankEnd, 10);
  EXPECT_EQ(run.initializations, 1) << "the map was reset instead of resumed in";
  for (int i = resumed; i < static_cast<int>(run.results.size()); ++i) {
    EXPECT_EQ(run.results[i].state, TrackingState::kTracking) << "frame " << i;
  }
  // One map, one scale: the frames after the interruption are consistent with those before.
  const double path = 0.1 * 89;
  EXPECT_LT(run.ape.translation.rmse, 0.02 * path) << "APE RMSE " << run.ape.translation.rmse;
}

// The camera is turning (1.5 deg per frame from frame 35) when the input stops at frame 50 and
// has stopped turning when it comes back at frame 60: the constant-velocity prediction
// overshoots the heading by 16.5 deg, ~150 px on this 65 deg wide view. The recovery search's
// rotation hypotheses find the pose on the first frame back, before BoW relocalization is
// needed (on these distinct random descriptors BoW would find it too, one step later).
TEST_F(RelocalizationTest, ResumesWhenTheCameraStoppedTurningDuringAnInterruption) {
  constexpr int kFrames = 80, kTurnBegin = 35, kTurnEnd = 50;
  constexpr double kTurnRate = 1.5 * M_PI / 180.0;
  Sequence sequence;
  std::mt19937_64 rng(17);
  for (int i = 0; i < kFrames; ++i) {
    const double yaw = kTurnRate * std::clamp(i - kTurnBegin, 0, kTurnEnd - kTurnBegin);
    const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.0, yaw, 0.0)),
                                 Eigen::Vector3d(0.1 * i, 0.05 * std::sin(i / 7.0), 0.0));
    sequence.truth.push_back(world_from_cam.Inverse());
    sequence.frames.push_back(testing::ObserveScene(scene_, *camera_, sequence.truth.back(),
                                                    testing::ObservationNoise(), &rng));
  }
  constexpr int kBlankBegin = kTurnEnd, kBlankEnd = kTurnEnd + 10;

  const auto run_with = [&](double hypothesis_threshold_rad, bool window_free_recovery = true) {
    SystemOptions options = Options(true);
    options.tracking.recovery_rotation_hypothesis_rad = hypothesis_threshold_rad;
    options.tracking.window_free_recovery = window_free_recovery;
    System system(params_, options);
    return RunSequence(&system, sequence, kBlankBegin, kBlankEnd);
  };
  const RunResult run = run_with(SystemOptions().tracking.recovery_rotation_hypothesis_rad);
  EXPECT_EQ(run.initializations, 1) << "the map was reset instead of resumed in";
  EXPECT_EQ(run.results[kBlankEnd].state, TrackingState::kTracking);
  EXPECT_FALSE(run.results[kBlankEnd].relocalized) << "resumed by relocalization, not recovery";
  for (int i = kBlankEnd; i < kFrames; ++i) {
    EXPECT_EQ(run.results[i].state, TrackingState::kTracking) << "frame " << i;
  }
  const double path = 0.1 * (kFrames - 1);
  EXPECT_LT(run.ape.translation.rmse, 0.02 * path) << "APE RMSE " << run.ape.translation.rmse;

  // With the extrapolated rotation as the only hypothesis the recovery search fails there (the
  // window-free search, which would find it without any hypothesis, turned off).
  const RunResult single = run_with(1e9, /*window_free_recovery=*/false);
  EXPECT_TRUE(single.results[kBlankEnd].state != TrackingState::kTracking ||
              single.results[kBlankEnd].relocalized);
}

// A kidnapped camera: after frame 59 the camera is carried back 4 m along the street (the input
// continues with the views of frames 20...), where the motion model cannot follow; BoW
// relocalization must find it in the map within a few frames.
TEST_F(RelocalizationTest, KidnappedCameraRelocalizesByBow) {
  const Sequence sequence = Kidnapped();
  System system(params_, Options(true));
  const RunResult run = RunSequence(&system, sequence);
  int relocalized_at = -1;
  for (int i = 60; i < static_cast<int>(run.results.size()); ++i) {
    if (run.results[i].relocalized) {
      relocalized_at = i;
      break;
    }
  }
  ASSERT_GE(relocalized_at, 60) << "no relocalization after the kidnapping";
  EXPECT_LT(relocalized_at - 60, 5);
  EXPECT_GE(run.stats.relocalizations, 1);
  EXPECT_EQ(run.initializations, 1) << "the map was reset instead of relocalized in";
  for (int i = relocalized_at; i < static_cast<int>(run.results.size()); ++i) {
    EXPECT_EQ(run.results[i].state, TrackingState::kTracking) << "frame " << i;
  }
  // The relocalized poses are in the map's frame: the same place as the first visit.
  const double path = 0.1 * 59;
  EXPECT_LT(run.ape.translation.rmse, 0.02 * path) << "APE RMSE " << run.ape.translation.rmse;
}

TEST_F(RelocalizationTest, WithoutVocabularyTheKidnappedCameraReinitializes) {
  System system(params_, Options(false));
  const RunResult run = RunSequence(&system, Kidnapped());
  EXPECT_EQ(run.stats.relocalizations, 0);
  EXPECT_GE(run.initializations, 2);
}

TEST_F(RelocalizationTest, LocalizationOnlyTracksASecondSequenceInTheSavedMap) {
  const Sequence mapping_run = MakeSequence(scene_, *camera_, 80, Eigen::Vector3d::Zero(), 21);
  System mapper(params_, Options(true));
  const RunResult first = RunSequence(&mapper, mapping_run);
  ASSERT_GT(first.keyframes, 3);

  // The second sequence drives 0.3 m to the side and 0.2 m higher over the same stretch.
  const Sequence second = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d(0.2, -0.2, 0.3), 22);
  SystemOptions options = Options(true);
  options.localization_only = true;
  System localizer(params_, options);
  localizer.LoadMap(first.map);
  EXPECT_EQ(localizer.NumKeyframes(), first.keyframes);
  const RunResult run = RunSequence(&localizer, second);

  int tracked = 0;
  for (const FrameResult& r : run.results) tracked += r.state == TrackingState::kTracking;
  EXPECT_GE(tracked, 0.9 * run.results.size()) << tracked << " of " << run.results.size();
  EXPECT_TRUE(run.results.front().relocalized);
  EXPECT_EQ(run.keyframes, first.keyframes) << "localization-only must not change the map";
  EXPECT_EQ(run.map.points.size(), first.map.points.size());
  EXPECT_EQ(run.initializations, 0);
  // Same frame as the mapping run: compare without alignment scale drift beyond the first run's.
  EXPECT_LT(run.ape.translation.rmse, std::max(0.05, 3.0 * first.ape.translation.rmse))
      << "mapping run APE " << first.ape.translation.rmse;
}

TEST_F(RelocalizationTest, LoadedMapIsExtendedWithoutLocalizationOnly) {
  const Sequence mapping_run = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d::Zero(), 31);
  System mapper(params_, Options(true));
  const RunResult first = RunSequence(&mapper, mapping_run);
  // Continue further along the street than the first run went.
  const Sequence second = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d(3.0, 0.0, 0.0), 32);
  System extender(params_, Options(true));
  extender.LoadMap(first.map);
  const RunResult run = RunSequence(&extender, second);
  int tracked = 0;
  for (const FrameResult& r : run.results) tracked += r.state == TrackingState::kTracking;
  EXPECT_GE(tracked, 0.9 * run.results.size());
  // New keyframes and points were added (redundant old keyframes may have been culled), with
  // ids after the loaded map's: every surviving id keeps its meaning.
  int new_keyframes = 0, new_points = 0;
  for (const auto& [id, kf] : run.map.keyframes) {
    if (first.map.keyframes.count(id)) continue;
    EXPECT_GE(id, first.map.NextFreeId());
    ++new_keyframes;
  }
  for (const auto& [id, point] : run.map.points) new_points += id >= first.map.NextFreeId();
  EXPECT_GE(new_keyframes, 2);
  EXPECT_GT(new_points, 100);
}

// Mapping.hold_loaded_keyframes: the loaded map's keyframes anchor the client's local BA
// windows and keep their poses; without it local BA moves them with the client's keyframes.
TEST_F(RelocalizationTest, HeldLoadedKeyframesKeepTheirPoses) {
  const Sequence mapping_run = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d::Zero(), 31);
  System mapper(params_, Options(true));
  const RunResult first = RunSequence(&mapper, mapping_run);
  const Sequence second = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d(3.0, 0.0, 0.0), 32);
  // Largest centre displacement of a loaded keyframe that survived, and how many survived.
  const auto moved = [&](bool hold, int* survivors) {
    SystemOptions options = Options(true);
    options.mapping.hold_loaded_keyframes = hold;
    System extender(params_, options);
    extender.LoadMap(first.map);
    const RunResult run = RunSequence(&extender, second);
    EXPECT_GT(run.keyframes, static_cast<int>(first.map.keyframes.size()) / 2);
    double max_moved = 0.0;
    *survivors = 0;
    for (const auto& [id, kf] : run.map.keyframes) {
      const auto loaded = first.map.keyframes.find(id);
      if (loaded == first.map.keyframes.end()) continue;
      ++*survivors;
      max_moved = std::max(max_moved, (kf.cam_from_world.Center() -
                                       loaded->second.cam_from_world.Center()).norm());
    }
    return max_moved;
  };
  int held_survivors = 0, free_survivors = 0;
  EXPECT_EQ(moved(true, &held_survivors), 0.0);
  EXPECT_GE(held_survivors, 3);
  EXPECT_GT(moved(false, &free_survivors), 1e-6);
  EXPECT_GE(free_survivors, 3);
}

// Mapping.use_loaded_keypoints: with it (default) local mapping triangulates the client's new
// points with the loaded keyframes' keypoints and fuses landmarks into them, so loaded
// keyframes observe points the client made; without it (a line cloud's information: server
// keyframes without keypoints) none of the client's points is observed by a loaded keyframe,
// while the client still tracks the loaded points and maps on its own.
TEST_F(RelocalizationTest, LoadedKeypointsObserveNewPointsOnlyWhenUsed) {
  const Sequence mapping_run = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d::Zero(), 31);
  System mapper(params_, Options(true));
  const RunResult first = RunSequence(&mapper, mapping_run);
  const Sequence second = MakeSequence(scene_, *camera_, 60, Eigen::Vector3d(1.0, 0.0, 0.0), 32);
  // Observations of the client's own points by loaded keyframes, and the client's points.
  const auto loaded_views = [&](bool use, int* new_points) {
    SystemOptions options = Options(true);
    options.mapping.use_loaded_keypoints = use;
    System extender(params_, options);
    extender.LoadMap(first.map);
    const RunResult run = RunSequence(&extender, second);
    int tracked = 0;
    for (const FrameResult& r : run.results) tracked += r.state == TrackingState::kTracking;
    EXPECT_GE(tracked, 0.9 * run.results.size()) << "use_loaded_keypoints " << use;
    int views = 0;
    *new_points = 0;
    for (const auto& [id, point] : run.map.points) {
      if (id < first.map.NextFreeId()) continue;
      ++*new_points;
      for (const auto& o : point.observations) views += first.map.keyframes.count(o.keyframe_id) > 0;
    }
    return views;
  };
  int used_points = 0, unused_points = 0;
  EXPECT_GT(loaded_views(true, &used_points), 50);
  EXPECT_EQ(loaded_views(false, &unused_points), 0);
  EXPECT_GT(used_points, 50);
  EXPECT_GT(unused_points, 50);
}

// The MapMergeTest camera along the facade of MakeSlabScene: frame i at x_of_frame(i), with
// a slight sway and turn.
Sequence MakeFacadeSequence(const testing::SyntheticScene& scene, const Camera& camera,
                            int frames, const std::function<double(int)>& x_of_frame,
                            std::mt19937_64* rng) {
  Sequence sequence;
  for (int i = 0; i < frames; ++i) {
    const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.0, 0.02 * std::sin(i / 9.0), 0.0)),
                                 Eigen::Vector3d(x_of_frame(i), 0.1 * std::sin(i / 7.0), 0.0));
    sequence.truth.push_back(world_from_cam.Inverse());
    sequence.frames.push_back(testing::ObserveScene(scene, camera, sequence.truth.back(),
                                                    testing::ObservationNoise(), rng));
  }
  return sequence;
}

// A map lost for good is kept and merged back by a loop (SlamMap segments): the camera tracks
// 7 m of a long facade, is carried (unseen: the gap) 17 m further to a part it never saw, starts
// a new map there and walks back. Where the two views overlap again, loop closing finds the old
// map, moves the new one into its frame and scale, and the frames of both end in one trajectory.
TEST(MapMergeTest, LostMapIsKeptAndMergedWhenTheCameraComesBack) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  const testing::SyntheticScene scene = testing::MakeSlabScene(9000, -4.0, 32.0, 4.0, 9.0, 51);
  std::mt19937_64 rng(52);
  constexpr int kBlankBegin = 70, kBlankEnd = 80, kFrames = 270;
  // 0.1 m per frame to x = 7 m; after the gap from x = 24 m back to x = 5 m.
  const Sequence sequence = MakeFacadeSequence(scene, *camera, kFrames, [&](int i) {
    return i < kBlankEnd ? 0.1 * i : 24.0 - 0.1 * (i - kBlankEnd);
  }, &rng);
  SystemOptions options;
  options.deterministic = true;
  options.seed = 5;
  options.vocabulary = TrainVocabulary(scene);
  options.tracking.max_lost_seconds = 1.5;  // give the first map up soon after the gap
  // Exact synthetic features keep tracking most points: more keyframes than the 90% default
  // gives, so that loop detection (which waits 10 keyframes in a new map and wants 3
  // consistent ones) has queries in the overlap.
  options.keyframe_policy.tracked_ratio = 0.95;

  System system(params, options);
  const RunResult run = RunSequence(&system, sequence, kBlankBegin, kBlankEnd);
  EXPECT_EQ(run.stats.maps_kept, 1);
  EXPECT_EQ(run.stats.maps_merged, 1);
  EXPECT_EQ(run.initializations, 2);
  int merged_loops = 0;
  for (const LoopEvent& loop : run.stats.loops) merged_loops += loop.merged_maps && loop.closed;
  EXPECT_EQ(merged_loops, 1);
  // Frames of both maps in one trajectory, consistent with the truth under one similarity.
  int before_gap = 0;
  for (const TimedPose& pose : run.trajectory) before_gap += pose.timestamp < 0.1 * kBlankBegin;
  EXPECT_GE(before_gap, kBlankBegin - 3);
  EXPECT_GE(run.trajectory.size(), 240u);
  const double path = 7.0 + 0.1 * (kFrames - kBlankEnd);
  EXPECT_LT(run.ape.translation.rmse, 0.02 * path) << "APE RMSE " << run.ape.translation.rmse;
  std::printf("kept %d, merged %d, %zu poses, APE %.3f m\n", run.stats.maps_kept,
              run.stats.maps_merged, run.trajectory.size(), run.ape.translation.rmse);

  // Without keeping lost maps the first map is dropped with its frames.
  options.loop_closing.merge_maps = false;
  System dropping(params, options);
  const RunResult dropped = RunSequence(&dropping, sequence, kBlankBegin, kBlankEnd);
  EXPECT_EQ(dropped.stats.maps_kept, 0);
  int dropped_before_gap = 0;
  for (const TimedPose& pose : dropped.trajectory) {
    dropped_before_gap += pose.timestamp < 0.1 * kBlankBegin;
  }
  EXPECT_EQ(dropped_before_gap, 0);
}

// The outputs hold one segment (SlamMap::OutputSegment): when the camera is lost for good and
// its new map never merges, the biggest map, as ORB-SLAM3 saves its atlas' biggest map. The
// camera tracks 7 m of the facade, is carried 17 m on (the gap) and goes on away from the first
// map: 30 frames after the gap leave the first map the bigger, 150 the new one.
TEST(MapMergeTest, OutputsHoldTheBiggestMapWhenALostMapNeverMerges) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  const testing::SyntheticScene scene = testing::MakeSlabScene(9000, -4.0, 44.0, 4.0, 9.0, 51);
  constexpr int kBlankBegin = 70, kBlankEnd = 80;
  const auto run_for = [&](int frames_after_gap) {
    std::mt19937_64 rng(52);
    const Sequence sequence =
        MakeFacadeSequence(scene, *camera, kBlankEnd + frames_after_gap, [&](int i) {
          return i < kBlankEnd ? 0.1 * i : 24.0 + 0.1 * (i - kBlankEnd);
        }, &rng);
    SystemOptions options;
    options.deterministic = true;
    options.seed = 5;
    options.vocabulary = TrainVocabulary(scene);
    options.tracking.max_lost_seconds = 1.5;
    System system(params, options);
    std::pair<RunResult, RunResult> outputs_and_left_out;
    outputs_and_left_out.first = RunSequence(&system, sequence, kBlankBegin, kBlankEnd);
    // The map left out, as `lcv slam` writes it beside the outputs.
    const std::vector<int> left_out = system.LeftOutMaps();
    EXPECT_EQ(left_out.size(), 1u);
    if (!left_out.empty()) {
      outputs_and_left_out.second.trajectory = system.FrameTrajectory(left_out.front());
      outputs_and_left_out.second.map = system.ExportMap(left_out.front());
    }
    return outputs_and_left_out;
  };
  // Poses of the trajectory and keyframes of the map file before and after the gap.
  const auto count = [&](const RunResult& run, int* poses_before, int* poses_after,
                         int* keyframes_before, int* keyframes_after) {
    *poses_before = *poses_after = *keyframes_before = *keyframes_after = 0;
    for (const TimedPose& pose : run.trajectory) {
      ++*(pose.timestamp < 0.1 * kBlankBegin ? poses_before : poses_after);
    }
    for (const auto& [id, kf] : run.map.keyframes) {
      ++*(kf.timestamp < 0.1 * kBlankBegin ? keyframes_before : keyframes_after);
    }
  };
  int poses_before = 0, poses_after = 0, keyframes_before = 0, keyframes_after = 0;
  const auto [short_tail, short_left_out] = run_for(30);
  EXPECT_EQ(short_tail.stats.maps_kept, 1);
  EXPECT_EQ(short_tail.stats.maps_merged, 0);
  EXPECT_EQ(short_tail.stats.maps_left_out, 1);
  EXPECT_EQ(short_tail.initializations, 2);
  count(short_tail, &poses_before, &poses_after, &keyframes_before, &keyframes_after);
  std::printf("30 frames after the gap: %d poses before it, %d after; map file %d keyframes "
              "before, %d after; APE %.3f m\n", poses_before, poses_after, keyframes_before,
              keyframes_after, short_tail.ape.translation.rmse);
  EXPECT_GE(poses_before, kBlankBegin - 3);
  EXPECT_EQ(poses_after, 0);
  EXPECT_GT(keyframes_before, 0);
  EXPECT_EQ(keyframes_after, 0);
  EXPECT_EQ(short_tail.keyframes, keyframes_before);  // the counts are the outputs'
  EXPECT_LT(short_tail.ape.translation.rmse, 0.02 * 7.0);
  // The map after the gap is left out of the outputs, not lost.
  count(short_left_out, &poses_before, &poses_after, &keyframes_before, &keyframes_after);
  std::printf("  left out: %d poses after the gap, map %d keyframes after it\n", poses_after,
              keyframes_after);
  EXPECT_EQ(poses_before, 0);
  EXPECT_GE(poses_after, 15);
  EXPECT_EQ(keyframes_before, 0);
  EXPECT_GT(keyframes_after, 0);

  const auto [long_tail, long_left_out] = run_for(150);
  EXPECT_EQ(long_tail.stats.maps_merged, 0);
  EXPECT_EQ(long_tail.stats.maps_left_out, 1);
  count(long_tail, &poses_before, &poses_after, &keyframes_before, &keyframes_after);
  std::printf("150 frames after the gap: %d poses before it, %d after; map file %d keyframes "
              "before, %d after\n", poses_before, poses_after, keyframes_before, keyframes_after);
  EXPECT_EQ(poses_before, 0);
  EXPECT_GE(poses_after, 140);
  EXPECT_EQ(keyframes_before, 0);
  EXPECT_GT(keyframes_after, 0);
  count(long_left_out, &poses_before, &poses_after, &keyframes_before, &keyframes_after);
  std::printf("  left out: %d poses before the gap, map %d keyframes before it\n", poses_before,
              keyframes_before);
  EXPECT_GE(poses_before, kBlankBegin - 3);
  EXPECT_EQ(poses_after, 0);
  EXPECT_GT(keyframes_before, 0);
  EXPECT_EQ(keyframes_after, 0);
}

// A camera that starts outside a loaded map (Tracking.start_outside_loaded_map): the map is
// made along the first 7 m of a long facade; the client starts 24 m along it, where the map
// never looked, and walks back. After max_lost_seconds it starts a map of its own; where the two
// views overlap, loop closing moves the run's map into the loaded one's frame and scale, and
// every frame it tracked is in the loaded map's frame. Without the setting the camera stays lost
// until it reaches the map.
TEST(MapMergeTest, CameraStartingOutsideALoadedMapMapsOnItsOwnAndMergesOnArrival) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  const testing::SyntheticScene scene = testing::MakeSlabScene(9000, -4.0, 32.0, 4.0, 9.0, 51);
  std::mt19937_64 rng(53);
  const auto make = [&](int frames, double x0, double step) {
    return MakeFacadeSequence(scene, *camera, frames, [&](int i) { return x0 + step * i; }, &rng);
  };
  const Sequence mapping_run = make(70, 0.0, 0.1);   // x = 0 .. 7 m
  const Sequence client = make(190, 24.0, -0.1);     // x = 24 .. 5 m
  SystemOptions options;
  options.deterministic = true;
  options.seed = 5;
  options.vocabulary = TrainVocabulary(scene);
  options.keyframe_policy.tracked_ratio = 0.95;  // as in LostMapIsKeptAndMergedWhenTheCameraComesBack
  System mapper(params, options);
  const RunResult first = RunSequence(&mapper, mapping_run);
  ASSERT_GE(first.map.keyframes.size(), 5u);

  // The loaded map's frame: the similarity from the truth to the mapping run's trajectory.
  std::vector<Eigen::Vector3d> truth_centres, map_centres;
  for (const TimedPose& pose : first.trajectory) {
    const size_t i = static_cast<size_t>(std::lround(pose.timestamp / 0.1));
    truth_centres.push_back(mapping_run.truth[i].Center());
    map_centres.push_back(pose.cam_from_world.Center());
  }
  Sim3d map_from_truth;
  ASSERT_TRUE(AlignUmeyama(truth_centres, map_centres, true, &map_from_truth));

  const auto run_client = [&](bool start_outside, int* tracked, double* error_in_map_frame) {
    SystemOptions client_options = options;
    client_options.tracking.start_outside_loaded_map = start_outside;
    System system(params, client_options);
    system.LoadMap(first.map);
    const RunResult run = RunSequence(&system, client);
    *tracked = 0;
    for (const FrameResult& r : run.results) *tracked += r.state == TrackingState::kTracking;
    // Metres, in the loaded map's frame, without an alignment of the client's own.
    double sum = 0.0;
    for (const TimedPose& pose : run.trajectory) {
      const size_t i = static_cast<size_t>(std::lround(pose.timestamp / 0.1));
      sum += ((map_from_truth * client.truth[i].Center() - pose.cam_from_world.Center()) /
              map_from_truth.scale)
                 .squaredNorm();
    }
    *error_in_map_frame = std::sqrt(sum / std::max<size_t>(1, run.trajectory.size()));
    std::printf("start_outside_loaded_map %d: tracked %d of %zu, %zu poses, kept %d, merged %d, "
                "in the map's frame %d, error there %.3f m\n",
                start_outside, *tracked, client.frames.size(), run.trajectory.size(),
                run.stats.maps_kept, run.stats.maps_merged,
                run.stats.trajectory_in_loaded_map_frame, *error_in_map_frame);
    return run;
  };
  int tracked = 0, tracked_waiting = 0;
  double error = 0.0, error_waiting = 0.0;
  const RunResult run = run_client(true, &tracked, &error);
  EXPECT_EQ(run.stats.maps_kept, 1);
  EXPECT_EQ(run.stats.maps_merged, 1);
  EXPECT_TRUE(run.stats.loaded_map);
  EXPECT_TRUE(run.stats.trajectory_in_loaded_map_frame);
  // Every tracked frame is in the merged trajectory (and the frames seen while initializing).
  EXPECT_GE(static_cast<int>(run.trajectory.size()), tracked);
  // The merged map holds the loaded keyframes (ids kept) and the run's own.
  int loaded_kept = 0;
  for (const auto& [id, kf] : first.map.keyframes) loaded_kept += run.map.keyframes.count(id) > 0;
  EXPECT_GT(loaded_kept, static_cast<int>(first.map.keyframes.size()) / 2);
  EXPECT_GT(run.map.keyframes.size(), first.map.keyframes.size());
  EXPECT_LT(error, 0.05);  // measured 0.004 m

  const RunResult waiting = run_client(false, &tracked_waiting, &error_waiting);
  EXPECT_EQ(waiting.stats.maps_kept, 0);
  EXPECT_GT(tracked, tracked_waiting + 40);  // measured 156 against 86 of 190

  // A camera that never reaches the loaded map: its trajectory is in its own frame (said by
  // the stats), and the exported map is the loaded one, so that writing it over the input
  // loses nothing.
  Sequence outside = client;
  outside.truth.resize(70);  // x = 24 .. 17 m
  outside.frames.resize(70);
  System alone(params, options);
  alone.LoadMap(first.map);
  const RunResult never = RunSequence(&alone, outside);
  EXPECT_EQ(never.stats.maps_kept, 1);
  EXPECT_EQ(never.stats.maps_merged, 0);
  EXPECT_FALSE(never.stats.trajectory_in_loaded_map_frame);
  EXPECT_GT(never.trajectory.size(), 30u);  // 70 frames, 3 s lost first: 38 measured
  ASSERT_EQ(never.map.keyframes.size(), first.map.keyframes.size());
  for (const auto& [id, kf] : first.map.keyframes) {
    ASSERT_TRUE(never.map.keyframes.count(id));
    EXPECT_LT((never.map.keyframes.at(id).cam_from_world.Center() - kf.cam_from_world.Center())
                  .norm(),
              1e-9);
  }
  // The run's own map, which `lcv slam` writes beside the loaded one (MAP.own).
  const Map own = alone.ExportMap(alone.TrajectoryMap());
  EXPECT_GE(own.keyframes.size(), 2u);
  for (const auto& [id, kf] : own.keyframes) EXPECT_EQ(first.map.keyframes.count(id), 0u);
  EXPECT_TRUE(alone.LeftOutMaps().empty());
}

TEST_F(RelocalizationTest, MapWithoutDescriptorsIsRejected) {
  const Sequence mapping_run = MakeSequence(scene_, *camera_, 30, Eigen::Vector3d::Zero(), 41);
  System mapper(params_, Options(true));
  RunResult first = RunSequence(&mapper, mapping_run);
  ASSERT_FALSE(first.map.keyframes.empty());
  first.map.keyframes.begin()->second.descriptors.clear();
  System system(params_, Options(true));
  EXPECT_THROW(system.LoadMap(first.map), std::invalid_argument);
}

}  // namespace
}  // namespace lcv::slam
