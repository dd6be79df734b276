#pragma once
// Internal to mapping/io: one reader per dataset layout (dataset_<format>.cc) and the helpers
// they share. Users call OpenDataset (dataset.h).
//
// A reader returns the whole sequence with its native camera (cols/rows may be 0 when the
// layout does not state them); OpenDataset then applies the camera override, fills and checks
// the image size and applies the frame selection.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mapping/io/dataset.h"

namespace lcv::mapping::internal {

// The native camera of a layout, or empty when the layout has none (a camera file is needed).
struct ReaderResult {
  std::unique_ptr<Dataset> dataset;
  // Where the camera came from, for error messages ("calib.txt", "camera.yaml", ...).
  std::string camera_source;
  // Image size when the reader knows it without opening an image (video); 0 otherwise.
  int image_cols = 0;
  int image_rows = 0;
};

ReaderResult ReadKitti(const std::string& path, const DatasetOptions& options);
ReaderResult ReadTum(const std::string& path, const DatasetOptions& options);
ReaderResult ReadTumMono(const std::string& path, const DatasetOptions& options);
ReaderResult ReadEuroc(const std::string& path, const DatasetOptions& options);
ReaderResult ReadLcv(const std::string& path, const DatasetOptions& options);
ReaderResult ReadImageFolder(const std::string& path, const DatasetOptions& options);
ReaderResult ReadVideo(const std::string& path, const DatasetOptions& options);

// "<dir>/<name>" without doubling the slash.
std::string JoinPath(const std::string& dir, const std::string& name);
// Last component of a folder path, ignoring a trailing slash ("a/b/" -> "b").
std::string FolderName(const std::string& path);
bool IsDirectory(const std::string& path);
bool IsFile(const std::string& path);
// Image files of a folder (by extension, case-insensitive), sorted by name, as full paths.
std::vector<std::string> ListImageFiles(const std::string& dir);
// camera.yaml, camera.yml or camera.json in dir, if any.
std::optional<std::string> FindCameraFile(const std::string& dir);
// The camera from options.camera_file, else from a camera file in dir; throws InputError
// naming `what` (the dataset path) when there is none. Size may be 0 (filled later).
slam::CameraParams RequireCameraFile(const std::string& dir, const std::string& what,
                                     const DatasetOptions& options, std::string* source);
// Sets frames[i].world_from_cam from the pose of ground_truth nearest in time, when within
// max_time_difference_s.
void AssignGroundTruthByTimestamp(const Trajectory& ground_truth, double max_time_difference_s,
                                  std::vector<DatasetFrame>* frames);
// Throws InputError(source, ...) unless the frames' timestamps strictly increase.
void CheckIncreasingTimestamps(const std::vector<DatasetFrame>& frames, const std::string& source);

}  // namespace lcv::mapping::internal
