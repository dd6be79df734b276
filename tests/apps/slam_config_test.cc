#include "apps/slam_config.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "mapping/io/atomic_file.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

namespace fs = std::filesystem;

std::string WriteConfig(const std::string& name, const std::string& text) {
  const fs::path path = fs::temp_directory_path() / ("lcv_slam_config_test_" + name);
  mapping::WriteFileAtomically(path.string(), text);
  return path.string();
}

slam::CameraParams TenFpsCamera() {
  slam::CameraParams camera;
  camera.cols = 640;
  camera.rows = 360;
  camera.fx = camera.fy = 400;
  camera.cx = 319.5;
  camera.cy = 179.5;
  camera.fps = 10;
  return camera;
}

// The options as `lcv slam` builds them: camera defaults only where the file set nothing.
slam::SystemOptions Effective(const std::string& config_path,
                              slam::CameraModel model = slam::CameraModel::kPerspective) {
  slam::SystemOptions options = OptionsWithoutCameraDefaults();
  if (!config_path.empty()) ReadSlamConfig(config_path, &options);
  slam::CameraParams camera = TenFpsCamera();
  camera.model = model;
  ApplyCameraDefaults(camera, &options);
  return options;
}

// Keyframes on a shorter travel in a line cloud are the wide cameras' default (0.1 median depths
// fisheye, 0.15 equirectangular); a perspective camera keeps the common travel rule (0). A
// file's value, 0 included, applies to every camera.
TEST(SlamConfig, LineCloudTravelFollowsTheCameraModelUnlessSet) {
  EXPECT_EQ(Effective("").keyframe_policy.max_travel_of_depth_in_line_cloud, 0.0);
  EXPECT_EQ(Effective("", slam::CameraModel::kFisheye).keyframe_policy
                .max_travel_of_depth_in_line_cloud,
            0.1);
  EXPECT_EQ(Effective("", slam::CameraModel::kEquirectangular).keyframe_policy
                .max_travel_of_depth_in_line_cloud,
            0.15);
  const std::string common = WriteConfig(
      "travel_common.yaml", "KeyframeInserter:\n  max_travel_of_depth_in_line_cloud: 0\n");
  EXPECT_EQ(Effective(common, slam::CameraModel::kFisheye).keyframe_policy
                .max_travel_of_depth_in_line_cloud,
            0.0);
  EXPECT_EQ(Effective(common, slam::CameraModel::kEquirectangular).keyframe_policy
                .max_travel_of_depth_in_line_cloud,
            0.0);
  const std::string set = WriteConfig(
      "travel_set.yaml", "KeyframeInserter:\n  max_travel_of_depth_in_line_cloud: 0.2\n");
  EXPECT_EQ(Effective(set).keyframe_policy.max_travel_of_depth_in_line_cloud, 0.2);
  EXPECT_EQ(Effective(set, slam::CameraModel::kEquirectangular).keyframe_policy
                .max_travel_of_depth_in_line_cloud,
            0.2);
}

// The line search's back-off is the 360-degree camera's default only (slam/match/
// line_search_backoff.h says why); a file's value, 0 included, applies to every camera.
TEST(SlamConfig, LineSearchBackoffFollowsTheCameraModelUnlessSet) {
  EXPECT_EQ(Effective("").line_cloud.line_search_backoff.misses, 0);
  EXPECT_EQ(Effective("", slam::CameraModel::kFisheye).line_cloud.line_search_backoff.misses, 0);
  EXPECT_EQ(
      Effective("", slam::CameraModel::kEquirectangular).line_cloud.line_search_backoff.misses, 2);
  const std::string off =
      WriteConfig("backoff_off.yaml", "LineCloud:\n  line_search_backoff_misses: 0\n");
  EXPECT_EQ(
      Effective(off, slam::CameraModel::kEquirectangular).line_cloud.line_search_backoff.misses,
      0);
  const std::string on =
      WriteConfig("backoff_on.yaml", "LineCloud:\n  line_search_backoff_misses: 1\n");
  EXPECT_EQ(Effective(on).line_cloud.line_search_backoff.misses, 1);
}

TEST(SlamConfig, CameraDefaultsFillOnlyWhatTheFileLeavesOut) {
  const slam::SystemOptions defaults = Effective("");
  EXPECT_EQ(defaults.keyframe_policy.max_frames, 10);  // one second of 10 fps video
  EXPECT_EQ(defaults.features.num_features,
            slam::DefaultNumFeatures(slam::CameraModel::kPerspective, 640, 360));

  // The file's KeyframeInserter.max_interval used to be overwritten by the camera's fps.
  const std::string path = WriteConfig(
      "set.yaml",
      "KeyframeInserter:\n  max_interval: 4\n  max_travel_of_depth: 0\n"
      "  max_travel_of_depth_in_line_cloud: 0.25\n  travel_min_interval: 1\n"
      "  line_cloud_fading_ratio: 0\n  line_cloud_fading_min: 12\n"
      "Feature:\n  max_num_keypoints: 1500\n"
      "LineCloud:\n  register_from_views: false\n  virtual_from_published: true\n"
      "  release_off_line_deg: 1.5\n  virtual_sigma_px: 1.5\n"
      "  track_restored_as_points_min_observations: 0\n"
      "  line_search_backoff_misses: 3\n  line_search_backoff_max_period: 6\n"
      "Mapping:\n  hold_loaded_keyframes: false\n  use_loaded_keypoints: false\n"
      "Tracking:\n  line_cloud_check_live_periods: 2.5\n  two_view_max_consecutive: 3\n"
      "  line_cloud_check_live_retries: 0\n  start_outside_loaded_map: false\n"
      "Relocalization:\n  in_line_cloud: false\n  line_cloud_max_trials: 50\n"
      "  line_cloud_live_max_trials: 5\n  line_cloud_min_inliers: 40\n"
      "LoopClosing:\n  keep_loaded_datum: false\n");
  const slam::SystemOptions set = Effective(path);
  EXPECT_EQ(set.keyframe_policy.max_frames, 4);
  EXPECT_EQ(defaults.keyframe_policy.max_travel_of_depth, 0.3);
  EXPECT_EQ(set.keyframe_policy.max_travel_of_depth, 0.0);  // switched off
  EXPECT_EQ(defaults.keyframe_policy.max_travel_of_depth_in_line_cloud, 0.0);
  EXPECT_EQ(set.keyframe_policy.max_travel_of_depth_in_line_cloud, 0.25);
  EXPECT_EQ(defaults.keyframe_policy.travel_min_frames, 2);
  EXPECT_EQ(set.keyframe_policy.travel_min_frames, 1);
  EXPECT_EQ(defaults.keyframe_policy.line_cloud_fading_ratio, 0.9);
  EXPECT_EQ(set.keyframe_policy.line_cloud_fading_ratio, 0.0);  // switched off
  EXPECT_EQ(defaults.keyframe_policy.line_cloud_fading_min, 30);
  EXPECT_EQ(set.keyframe_policy.line_cloud_fading_min, 12);
  EXPECT_EQ(set.features.num_features, 1500);
  EXPECT_TRUE(defaults.line_cloud.view_registration.enabled);
  EXPECT_FALSE(set.line_cloud.view_registration.enabled);
  EXPECT_FALSE(defaults.line_cloud.virtual_from_published);
  EXPECT_TRUE(set.line_cloud.virtual_from_published);
  EXPECT_EQ(defaults.line_cloud.release_off_line_deg, 0.0);
  EXPECT_EQ(set.line_cloud.release_off_line_deg, 1.5);
  EXPECT_EQ(defaults.line_cloud.virtual_sigma_px, 0.0);
  EXPECT_EQ(set.line_cloud.virtual_sigma_px, 1.5);
  EXPECT_EQ(defaults.line_cloud.track_restored_as_points_min_observations, 2);
  EXPECT_EQ(set.line_cloud.track_restored_as_points_min_observations, 0);  // the paper's eq. 6
  EXPECT_EQ(defaults.line_cloud.line_search_backoff.misses, 0);  // perspective
  EXPECT_EQ(set.line_cloud.line_search_backoff.misses, 3);
  EXPECT_EQ(defaults.line_cloud.line_search_backoff.max_period, 4);
  EXPECT_EQ(set.line_cloud.line_search_backoff.max_period, 6);
  EXPECT_TRUE(defaults.mapping.hold_loaded_keyframes);
  EXPECT_FALSE(set.mapping.hold_loaded_keyframes);
  EXPECT_TRUE(defaults.tracking.start_outside_loaded_map);
  EXPECT_FALSE(set.tracking.start_outside_loaded_map);
  EXPECT_TRUE(defaults.loop_closing.keep_loaded_datum);
  EXPECT_FALSE(set.loop_closing.keep_loaded_datum);
  EXPECT_TRUE(defaults.mapping.use_loaded_keypoints);
  EXPECT_FALSE(set.mapping.use_loaded_keypoints);
  EXPECT_EQ(defaults.tracking.line_cloud_check_live_periods, 1.0);
  EXPECT_EQ(set.tracking.line_cloud_check_live_periods, 2.5);
  EXPECT_EQ(defaults.tracking.two_view_max_consecutive, 2);
  EXPECT_EQ(set.tracking.two_view_max_consecutive, 3);
  EXPECT_EQ(defaults.tracking.line_cloud_check_live_retries, 4);
  EXPECT_EQ(set.tracking.line_cloud_check_live_retries, 0);
  EXPECT_TRUE(defaults.relocalization.in_line_cloud);
  EXPECT_FALSE(set.relocalization.in_line_cloud);
  EXPECT_EQ(defaults.relocalization.line_cloud_max_trials, 300);
  EXPECT_EQ(set.relocalization.line_cloud_max_trials, 50);
  EXPECT_EQ(defaults.relocalization.line_cloud_live_max_trials, 30);
  EXPECT_EQ(set.relocalization.line_cloud_live_max_trials, 5);
  EXPECT_EQ(defaults.relocalization.line_cloud_min_inliers, 30);
  EXPECT_EQ(set.relocalization.line_cloud_min_inliers, 40);
  fs::remove(path);
}

TEST(SlamConfig, BadSettingsNameTheFileAndTheKey) {
  const std::string zero = WriteConfig("zero.yaml", "KeyframeInserter:\n  max_interval: 0\n");
  try {
    Effective(zero);
    FAIL() << "max_interval 0 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(zero), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("KeyframeInserter.max_interval"), std::string::npos)
        << e.what();
  }
  const std::string typo = WriteConfig("typo.yaml", "KeyframeInserter:\n  max_intervall: 4\n");
  EXPECT_THROW(Effective(typo), InputError);
  fs::remove(zero);
  fs::remove(typo);
}

}  // namespace
}  // namespace lcv::apps
