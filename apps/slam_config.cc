// `lcv slam --config`: the system settings file. See apps/slam_config.h.
#include "apps/slam_config.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/yaml_subset.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

// A setting OptionsWithoutCameraDefaults leaves for ApplyCameraDefaults (the file's range starts
// at 0, and 0 there has a meaning of its own).
constexpr double kFollowsCamera = -1.0;
constexpr int kFollowsCameraCount = -1;

// Reads one number of a settings section into *value, checking its range.
template <typename T>
void ReadSetting(const json& section, const std::string& section_name, const std::string& key,
                 const std::string& path, double min_value, double max_value, T* value,
                 std::vector<std::string>* used) {
  used->push_back(key);
  if (!section.contains(key)) return;
  const json& v = section.at(key);
  if (!v.is_number()) {
    throw InputError(path, section_name + "." + key + ": expected a number");
  }
  const double d = v.get<double>();
  if (!(d >= min_value && d <= max_value)) {
    std::ostringstream what;
    what << section_name << "." << key << ": " << d << " is outside [" << min_value << ", "
         << max_value << "]";
    throw InputError(path, what.str());
  }
  if (std::is_integral<T>::value && d != std::floor(d)) {
    throw InputError(path, section_name + "." + key + ": expected an integer");
  }
  *value = static_cast<T>(d);
}

void ReadBool(const json& section, const std::string& section_name, const std::string& key,
              const std::string& path, bool* value, std::vector<std::string>* used) {
  used->push_back(key);
  if (!section.contains(key)) return;
  if (!section.at(key).is_boolean()) {
    throw InputError(path, section_name + "." + key + ": expected true or false");
  }
  *value = section.at(key).get<bool>();
}

void RejectUnknown(const json& section, const std::string& section_name,
                   const std::vector<std::string>& used, const std::string& path) {
  for (auto it = section.begin(); it != section.end(); ++it) {
    if (std::find(used.begin(), used.end(), it.key()) == used.end()) {
      throw InputError(path, section_name + "." + it.key() + ": unknown setting");
    }
  }
}

}  // namespace

void ReadSlamConfig(const std::string& path, slam::SystemOptions* options) {
  const std::string text = mapping::ReadTextFile(path);
  json root;
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    try {
      root = json::parse(text);
    } catch (const json::parse_error& e) {
      throw InputError(path, std::string("invalid JSON: ") + e.what());
    }
  } else {
    root = mapping::ParseYamlSubset(text, path);
  }
  if (root.is_null()) return;
  if (!root.is_object()) throw InputError(path, "expected a mapping of sections");
  const std::vector<std::string> sections{"Camera",           "Feature",        "Initializer",
                                          "Tracking",         "Mapping",        "KeyframeInserter",
                                          "Relocalization",   "LoopClosing",    "LineCloud",
                                          "System"};
  for (auto it = root.begin(); it != root.end(); ++it) {
    if (std::find(sections.begin(), sections.end(), it.key()) == sections.end()) {
      throw InputError(path, it.key() + ": unknown section (expected one of Camera, Feature, "
                             "Initializer, Tracking, Mapping, KeyframeInserter, Relocalization, "
                             "LoopClosing, LineCloud, System)");
    }
    if (it.key() != "Camera" && !it.value().is_object()) {
      throw InputError(path, it.key() + ": expected a mapping");
    }
  }
  auto section = [&](const char* name) { return root.contains(name) ? root.at(name) : json::object(); };
  std::vector<std::string> used;
  const json feature = section("Feature");
  ReadSetting(feature, "Feature", "max_num_keypoints", path, 100, 20000, &options->features.num_features, &used);
  ReadSetting(feature, "Feature", "scale_factor", path, 1.01, 2.0, &options->features.scale_factor, &used);
  ReadSetting(feature, "Feature", "num_levels", path, 1, 16, &options->features.num_levels, &used);
  ReadSetting(feature, "Feature", "ini_fast_threshold", path, 1, 255, &options->features.ini_fast_threshold, &used);
  ReadSetting(feature, "Feature", "min_fast_threshold", path, 1, 255, &options->features.min_fast_threshold, &used);
  RejectUnknown(feature, "Feature", used, path);

  used.clear();
  const json init = section("Initializer");
  slam::InitializerOptions& io = options->initializer;
  ReadSetting(init, "Initializer", "num_min_matches", path, 8, 100000, &io.min_matches, &used);
  ReadSetting(init, "Initializer", "min_num_triangulated", path, 8, 100000, &io.two_view.min_num_triangulated, &used);
  ReadSetting(init, "Initializer", "parallax_deg_threshold", path, 0.0, 45.0, &io.two_view.parallax_threshold_deg, &used);
  ReadSetting(init, "Initializer", "reprojection_error_threshold_rad", path, 1e-5, 0.1, &io.two_view.max_angular_error_rad, &used);
  ReadSetting(init, "Initializer", "num_ransac_iterations", path, 1, 100000, &io.two_view.max_ransac_trials, &used);
  ReadSetting(init, "Initializer", "search_window_px", path, 1.0, 10000.0, &io.matching.window_px, &used);
  ReadBool(init, "Initializer", "use_homography", path, &io.two_view.use_homography, &used);
  RejectUnknown(init, "Initializer", used, path);

  used.clear();
  const json tracking = section("Tracking");
  slam::TrackingSettings& ts = options->tracking;
  ReadSetting(tracking, "Tracking", "motion_search_radius_px", path, 1.0, 1000.0, &ts.motion_search_radius_px, &used);
  ReadSetting(tracking, "Tracking", "local_map_radius_factor", path, 0.1, 100.0, &ts.local_map_radius_factor, &used);
  ReadSetting(tracking, "Tracking", "min_tracked_inliers", path, 6, 10000, &ts.min_tracked_inliers, &used);
  ReadSetting(tracking, "Tracking", "lost_after_frames", path, 1, 100000, &ts.lost_after_frames, &used);
  ReadSetting(tracking, "Tracking", "max_view_angle_deg", path, 1.0, 180.0, &ts.max_view_angle_deg, &used);
  ReadSetting(tracking, "Tracking", "search_threads", path, 1, 64, &ts.search_threads, &used);
  ReadSetting(tracking, "Tracking", "max_lost_seconds", path, 0.0, 1.0e9, &ts.max_lost_seconds, &used);
  ReadBool(tracking, "Tracking", "start_outside_loaded_map", path, &ts.start_outside_loaded_map,
           &used);
  ReadBool(tracking, "Tracking", "two_view_recovery", path, &ts.two_view_recovery, &used);
  ReadSetting(tracking, "Tracking", "line_cloud_check_live_periods", path, 0.0, 100.0, &ts.line_cloud_check_live_periods, &used);
  ReadSetting(tracking, "Tracking", "line_cloud_check_live_retries", path, 0, 1000, &ts.line_cloud_check_live_retries, &used);
  ReadSetting(tracking, "Tracking", "two_view_max_consecutive", path, 1, 1000, &ts.two_view_max_consecutive, &used);
  RejectUnknown(tracking, "Tracking", used, path);

  used.clear();
  const json mapping_section = section("Mapping");
  slam::MappingSettings& ms = options->mapping;
  ReadSetting(mapping_section, "Mapping", "max_triangulation_neighbours", path, 1, 100, &ms.max_triangulation_neighbours, &used);
  ReadSetting(mapping_section, "Mapping", "local_ba_iterations", path, 1, 1000, &ms.local_ba_iterations, &used);
  ReadSetting(mapping_section, "Mapping", "max_local_ba_keyframes", path, 1, 1000, &ms.max_local_ba_keyframes, &used);
  ReadSetting(mapping_section, "Mapping", "min_parallax_deg", path, 0.0, 45.0, &ms.min_parallax_deg, &used);
  ReadSetting(mapping_section, "Mapping", "redundant_keyframe_ratio", path, 0.0, 1.0, &ms.redundant_keyframe_ratio, &used);
  ReadBool(mapping_section, "Mapping", "hold_loaded_keyframes", path, &ms.hold_loaded_keyframes, &used);
  ReadBool(mapping_section, "Mapping", "use_loaded_keypoints", path, &ms.use_loaded_keypoints, &used);
  ReadSetting(mapping_section, "Mapping", "keyframe_queue_capacity", path, 1, 1000, &ms.keyframe_queue_capacity, &used);
  ReadBool(mapping_section, "Mapping", "fuse_duplicates", path, &ms.fuse_duplicates, &used);
  ReadBool(mapping_section, "Mapping", "cull_keyframes", path, &ms.cull_keyframes, &used);
  RejectUnknown(mapping_section, "Mapping", used, path);

  used.clear();
  const json kf = section("KeyframeInserter");
  slam::KeyframePolicyOptions& kp = options->keyframe_policy;
  ReadSetting(kf, "KeyframeInserter", "min_interval", path, 0, 100000, &kp.min_frames, &used);
  ReadSetting(kf, "KeyframeInserter", "max_interval", path, 1, 100000, &kp.max_frames, &used);
  ReadSetting(kf, "KeyframeInserter", "tracked_ratio", path, 0.0, 1.0, &kp.tracked_ratio, &used);
  ReadSetting(kf, "KeyframeInserter", "min_tracked", path, 0, 100000, &kp.min_tracked, &used);
  ReadSetting(kf, "KeyframeInserter", "weak_tracking", path, 0, 100000, &kp.weak_tracking, &used);
  ReadSetting(kf, "KeyframeInserter", "weak_ratio", path, 0.0, 1.0, &kp.weak_ratio, &used);
  ReadSetting(kf, "KeyframeInserter", "max_travel_of_depth", path, 0.0, 100.0,
              &kp.max_travel_of_depth, &used);
  ReadSetting(kf, "KeyframeInserter", "max_travel_of_depth_in_line_cloud", path, 0.0, 100.0,
              &kp.max_travel_of_depth_in_line_cloud, &used);
  ReadSetting(kf, "KeyframeInserter", "travel_min_interval", path, 1, 100000,
              &kp.travel_min_frames, &used);
  ReadSetting(kf, "KeyframeInserter", "line_cloud_fading_ratio", path, 0.0, 1.0,
              &kp.line_cloud_fading_ratio, &used);
  ReadSetting(kf, "KeyframeInserter", "line_cloud_fading_min", path, 0, 100000,
              &kp.line_cloud_fading_min, &used);
  RejectUnknown(kf, "KeyframeInserter", used, path);

  used.clear();
  const json reloc = section("Relocalization");
  slam::RelocalizationSettings& rs = options->relocalization;
  ReadBool(reloc, "Relocalization", "enabled", path, &rs.enabled, &used);
  ReadSetting(reloc, "Relocalization", "max_candidates", path, 1, 1000, &rs.max_candidates, &used);
  ReadSetting(reloc, "Relocalization", "min_inliers", path, 6, 100000, &rs.min_inliers, &used);
  ReadBool(reloc, "Relocalization", "in_line_cloud", path, &rs.in_line_cloud, &used);
  ReadSetting(reloc, "Relocalization", "line_cloud_max_trials", path, 1, 100000,
              &rs.line_cloud_max_trials, &used);
  ReadSetting(reloc, "Relocalization", "line_cloud_live_max_trials", path, 1, 100000,
              &rs.line_cloud_live_max_trials, &used);
  ReadSetting(reloc, "Relocalization", "line_cloud_min_inliers", path, 6, 100000,
              &rs.line_cloud_min_inliers, &used);
  RejectUnknown(reloc, "Relocalization", used, path);

  used.clear();
  const json loop = section("LoopClosing");
  slam::LoopClosingSettings& ls = options->loop_closing;
  ReadBool(loop, "LoopClosing", "enabled", path, &ls.enabled, &used);
  ReadBool(loop, "LoopClosing", "global_bundle_adjustment", path, &ls.global_bundle_adjustment, &used);
  ReadBool(loop, "LoopClosing", "merge_maps", path, &ls.merge_maps, &used);
  ReadBool(loop, "LoopClosing", "keep_loaded_datum", path, &ls.keep_loaded_datum, &used);
  ReadSetting(loop, "LoopClosing", "global_ba_iterations", path, 1, 1000, &ls.global_ba_iterations, &used);
  RejectUnknown(loop, "LoopClosing", used, path);

  used.clear();
  const json lines = section("LineCloud");
  slam::LineCloudSettings& lc = options->line_cloud;
  ReadBool(lines, "LineCloud", "match_lines", path, &lc.match_lines, &used);
  ReadSetting(lines, "LineCloud", "track_restored_as_points_min_observations", path, 0, 100000,
              &lc.track_restored_as_points_min_observations, &used);
  ReadSetting(lines, "LineCloud", "step_px", path, 1.0, 100.0, &lc.matching.step_px, &used);
  ReadSetting(lines, "LineCloud", "radius_px", path, 1.0, 100.0, &lc.matching.radius_px, &used);
  ReadSetting(lines, "LineCloud", "max_hamming_distance", path, 1, 256,
              &lc.matching.max_hamming_distance, &used);
  ReadSetting(lines, "LineCloud", "max_view_angle_deg", path, 1.0, 180.0,
              &lc.matching.max_view_angle_deg, &used);
  ReadBool(lines, "LineCloud", "check_scale_range", path, &lc.matching.check_scale_range, &used);
  ReadSetting(lines, "LineCloud", "search_threads", path, 1, 64, &lc.matching.num_threads, &used);
  ReadSetting(lines, "LineCloud", "registration_min_inliers", path, 6, 100000,
              &lc.relocalizer.registration.min_inliers, &used);
  ReadSetting(lines, "LineCloud", "registration_candidates", path, 1, 1000,
              &lc.relocalizer.max_candidates, &used);
  ReadSetting(lines, "LineCloud", "registration_vote_pool", path, 0, 100000,
              &lc.relocalizer.vote_pool, &used);
  ReadBool(lines, "LineCloud", "registration_query_from_landmarks", path,
           &lc.relocalizer.query_from_landmarks, &used);
  ReadSetting(lines, "LineCloud", "warn_after_keyframes", path, 1, 1000000,
              &lc.warn_after_keyframes, &used);
  ReadBool(lines, "LineCloud", "close_loops", path, &lc.close_loops, &used);
  ReadSetting(lines, "LineCloud", "snapshot_server_keyframes", path, 0, 100000,
              &lc.snapshot_server_keyframes, &used);
  ReadSetting(lines, "LineCloud", "line_search_backoff_misses", path, 0, 1000,
              &lc.line_search_backoff.misses, &used);
  ReadSetting(lines, "LineCloud", "line_search_backoff_max_period", path, 1, 1000,
              &lc.line_search_backoff.max_period, &used);
  ReadBool(lines, "LineCloud", "loop_holds_keyframes_made_in_line_cloud", path,
           &lc.loop.hold_keyframes_made_in_line_cloud, &used);
  ReadSetting(lines, "LineCloud", "detach_below_restored", path, 0, 100000,
              &lc.loop.detach_below_restored, &used);
  ReadSetting(lines, "LineCloud", "detach_beyond_depths", path, 0.0, 1000.0,
              &lc.loop.detach_beyond_depths, &used);
  ReadSetting(lines, "LineCloud", "detach_after_keyframes", path, 1, 100000,
              &lc.loop.detach_after_keyframes, &used);
  ReadBool(lines, "LineCloud", "global_ba_frees_line_cloud", path, &lc.global_ba_frees_line_cloud, &used);
  ReadBool(lines, "LineCloud", "global_ba_frees_server_keyframes", path, &lc.global_ba_frees_server_keyframes, &used);
  ReadBool(lines, "LineCloud", "global_ba_keeps_server_datum", path, &lc.global_ba_keeps_server_datum, &used);
  ReadBool(lines, "LineCloud", "local_ba_frees_line_cloud", path, &lc.local_ba_frees_line_cloud, &used);
  ReadSetting(lines, "LineCloud", "local_ba_free_server_keyframes", path, 0, 1000,
              &lc.local_ba_free_server_keyframes, &used);
  ReadBool(lines, "LineCloud", "register_from_views", path, &lc.view_registration.enabled,
           &used);
  ReadBool(lines, "LineCloud", "virtual_from_published", path, &lc.virtual_from_published, &used);
  ReadSetting(lines, "LineCloud", "release_off_line_deg", path, 0.0, 90.0, &lc.release_off_line_deg,
              &used);
  ReadSetting(lines, "LineCloud", "virtual_sigma_px", path, 0.0, 1000.0, &lc.virtual_sigma_px, &used);
  used.push_back("virtual_information");
  if (lines.contains("virtual_information")) {
    const json& value = lines.at("virtual_information");
    const std::string text = value.is_string() ? value.get<std::string>() : std::string();
    if (text != "constant" && text != "derived") {
      throw InputError(path, "LineCloud.virtual_information: expected constant or derived, not " +
                                 value.dump());
    }
    lc.derived_virtual_information = text == "derived";
  }
  RejectUnknown(lines, "LineCloud", used, path);

  used.clear();
  const json system = section("System");
  ReadBool(system, "System", "deterministic", path, &options->deterministic, &used);
  ReadSetting(system, "System", "seed", path, 0, 9.0e15, &options->seed, &used);
  ReadSetting(system, "System", "background_nice", path, 0, 19, &options->background_nice, &used);
  RejectUnknown(system, "System", used, path);
}

slam::SystemOptions OptionsWithoutCameraDefaults() {
  slam::SystemOptions options;
  options.features.num_features = 0;
  options.keyframe_policy.max_frames = 0;
  options.keyframe_policy.max_travel_of_depth_in_line_cloud = kFollowsCamera;
  options.line_cloud.line_search_backoff.misses = kFollowsCameraCount;
  return options;
}

void ApplyCameraDefaults(const slam::CameraParams& camera, slam::SystemOptions* options) {
  if (options->features.num_features == 0) {
    options->features.num_features = slam::DefaultNumFeatures(camera.model, camera.cols, camera.rows);
  }
  if (options->keyframe_policy.max_frames == 0) {
    options->keyframe_policy.max_frames =
        std::max(1, static_cast<int>(std::lround(camera.fps > 0 ? camera.fps : 10.0)));
  }
  // Why by camera model: slam/module/keyframe_policy.h, max_travel_of_depth_in_line_cloud.
  double& travel_in_line_cloud = options->keyframe_policy.max_travel_of_depth_in_line_cloud;
  if (travel_in_line_cloud == kFollowsCamera) {
    switch (camera.model) {
      case slam::CameraModel::kFisheye: travel_in_line_cloud = 0.1; break;
      case slam::CameraModel::kEquirectangular: travel_in_line_cloud = 0.15; break;
      case slam::CameraModel::kPerspective: travel_in_line_cloud = 0.0; break;
    }
  }
  // Why by camera model: slam/match/line_search_backoff.h, LineSearchBackoffOptions::misses.
  int& backoff_misses = options->line_cloud.line_search_backoff.misses;
  if (backoff_misses == kFollowsCameraCount) {
    switch (camera.model) {
      case slam::CameraModel::kEquirectangular: backoff_misses = 2; break;
      case slam::CameraModel::kFisheye:
      case slam::CameraModel::kPerspective: backoff_misses = 0; break;
    }
  }
}

}  // namespace lcv::apps
