// Map-reuse benchmark (not run by ctest): save, load, localize. For a scene with two sequences
// of the same place (e.g. `lcv synth --scenario tracking`, whose client drives almost the map
// sequence's path):
//   1. mapping run on the map sequence -> System::ExportMap -> mapping::WriteMap (.lcmap);
//   2. mapping::ReadMap -> a new System, LoadMap, options.localization_only -> the client
//      sequence;
// and prints the share of the client's frames tracked, the relocalizations, the client's APE
// (Sim(3)-aligned on its own, and under the mapping run's alignment, i.e. in the saved map's
// frame: a localization that is consistent with the map keeps that error small) next to the
// mapping run's APE, and the map's write / read / LoadMap times. The target: >= 90% of
// the client's frames tracked with an APE close to the mapping run's.
//
// Usage: bench_map_reuse [--vocabulary FILE] [--map-sequence NAME] [--query-sequence NAME]
//                        [--map-out FILE] [--num-features N] [--threads] [--realtime]
//                        [--json FILE] SCENE_DIR ...
//   --map-out  where the map is written (default: a file in the temporary directory, removed).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "bench/slam_bench_common.h"
#include "mapping/io/map_file.h"

namespace {

using namespace lcv;
using Clock = std::chrono::steady_clock;

struct BenchOptions {
  bench::CommonOptions common;
  std::string map_sequence = "map";
  std::string query_sequence = "client";
  std::string map_out;
};

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

nlohmann::json RunDataset(const std::string& path, const BenchOptions& options,
                          const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
  const bench::LoadedSequence mapping_sequence = bench::LoadSequence(path, options.map_sequence);
  const bench::LoadedSequence query = bench::LoadSequence(path, options.query_sequence);
  const char* model = slam::CameraModelName(query.camera.model);

  // 1. Mapping run and save.
  slam::SystemOptions mapping_options =
      bench::BenchSystemOptions(mapping_sequence.camera, options.common, vocabulary);
  const bench::SystemRun mapping_run = bench::RunSystem(
      mapping_sequence, mapping_options, nullptr, nullptr, true, std::string(model) + " mapping",
      options.common.realtime);
  const bench::ApeSummary mapping_ape = bench::Sim3Ape(mapping_sequence, mapping_run.trajectory);
  const std::string map_path =
      !options.map_out.empty()
          ? options.map_out
          : (std::filesystem::temp_directory_path() /
             ("bench_map_reuse_" + std::to_string(::getpid()) + ".lcmap"))
                .string();
  auto t0 = Clock::now();
  mapping::WriteMap(*mapping_run.map, map_path);
  const double write_s = SecondsSince(t0);
  const auto file_bytes = std::filesystem::file_size(map_path);

  // 2. Load and localize.
  t0 = Clock::now();
  const slam::Map loaded = mapping::ReadMap(map_path);
  const double read_s = SecondsSince(t0);
  if (options.map_out.empty()) std::filesystem::remove(map_path);
  slam::SystemOptions query_options =
      bench::BenchSystemOptions(query.camera, options.common, vocabulary);
  query_options.localization_only = true;
  const bench::SystemRun query_run =
      bench::RunSystem(query, query_options, &loaded, nullptr, false,
                       std::string(model) + " localization", options.common.realtime);
  const int tracked = bench::CountTracked(query_run.results);
  int first_tracked = -1;
  for (size_t k = 0; k < query_run.results.size(); ++k) {
    if (query_run.results[k].state == slam::TrackingState::kTracking) {
      first_tracked = query_run.frame_index[k];
      break;
    }
  }
  const bench::ApeSummary query_ape = bench::Sim3Ape(query, query_run.trajectory);
  std::optional<bench::AlignedError> in_map_frame;
  if (!mapping_ape.problem) {
    in_map_frame = bench::ErrorUnderAlignment(query, query_run.trajectory,
                                              mapping_ape.gt_from_est, -1e300, 1e300);
  }
  const double tracked_percent =
      query.images.empty() ? 0.0 : 100.0 * tracked / static_cast<double>(query.images.size());

  std::printf("%s (%s, %dx%d): map '%s' %zu frames -> localize '%s' %zu frames\n", path.c_str(),
              model, query.camera.cols, query.camera.rows, options.map_sequence.c_str(),
              mapping_sequence.images.size(), options.query_sequence.c_str(), query.images.size());
  std::printf("  mapping run: tracked %d/%zu, keyframes %d, points %d, APE %s%.3f m (%.2f%%), "
              "wall %.1f s\n",
              bench::CountTracked(mapping_run.results), mapping_sequence.images.size(),
              mapping_run.keyframes, mapping_run.landmarks, mapping_ape.problem ? "n/a " : "",
              mapping_ape.rmse_m, mapping_ape.percent_of_path, mapping_run.wall_s);
  std::printf("  map file %.2f MB: write %.1f ms, read %.1f ms, LoadMap %.1f ms (load total "
              "%.1f ms)\n",
              file_bytes / 1e6, 1e3 * write_s, 1e3 * read_s, 1e3 * query_run.load_map_s,
              1e3 * (read_s + query_run.load_map_s));
  std::printf("  localization: tracked %d/%zu = %.1f%% (first at frame %d), relocalizations %d, "
              "keyframes %d (map had %zu), wall %.1f s\n",
              tracked, query.images.size(), tracked_percent, first_tracked,
              query_run.stats.relocalizations, query_run.keyframes, loaded.keyframes.size(),
              query_run.wall_s);
  if (query_ape.problem) {
    std::printf("  localization APE: %s\n", query_ape.problem->c_str());
  } else {
    std::printf("  localization APE (own Sim3) %.3f m (%.2f%%)", query_ape.rmse_m,
                query_ape.percent_of_path);
    if (in_map_frame) {
      std::printf("; in the map's frame (mapping run's alignment) %.3f m, max %.3f m",
                  in_map_frame->rmse_m, in_map_frame->max_m);
    }
    std::printf("  [target: >= 90%% tracked, APE close to the mapping run's]\n");
  }
  std::fflush(stdout);

  nlohmann::json j;
  j["dataset"] = path;
  j["camera_model"] = model;
  j["map_frames"] = mapping_sequence.images.size();
  j["map_keyframes"] = mapping_run.keyframes;
  j["map_points"] = mapping_run.landmarks;
  j["map_file_bytes"] = file_bytes;
  j["map_write_ms"] = 1e3 * write_s;
  j["map_read_ms"] = 1e3 * read_s;
  j["load_map_ms"] = 1e3 * query_run.load_map_s;
  if (!mapping_ape.problem) j["mapping_ape_rmse_m"] = mapping_ape.rmse_m;
  j["query_frames"] = query.images.size();
  j["query_tracked"] = tracked;
  j["query_tracked_percent"] = tracked_percent;
  j["query_first_tracked"] = first_tracked;
  j["query_relocalizations"] = query_run.stats.relocalizations;
  j["query_keyframes_after"] = query_run.keyframes;
  if (!query_ape.problem) j["query_ape_rmse_m"] = query_ape.rmse_m;
  if (in_map_frame) j["query_ape_in_map_frame_m"] = in_map_frame->rmse_m;
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  std::vector<std::string> datasets;
  const int status = bench::ParseBenchArguments(
      argc, argv,
      "usage: bench_map_reuse [--vocabulary FILE] [--map-sequence NAME] [--query-sequence NAME] "
      "[--map-out FILE] [--num-features N] [--threads] [--realtime] [--json FILE] SCENE_DIR ...",
      "bench_map_reuse: give at least one scene folder with two sequences "
      "(lcv synth --scenario tracking ...)",
      [&](const std::string& arg, int* i) {
        if (arg == "--map-sequence") {
          options.map_sequence = bench::OptionValue(argc, argv, i);
        } else if (arg == "--query-sequence") {
          options.query_sequence = bench::OptionValue(argc, argv, i);
        } else if (arg == "--map-out") {
          options.map_out = bench::OptionValue(argc, argv, i);
        } else {
          return false;
        }
        return true;
      },
      &options.common, &datasets);
  if (status >= 0) return status;
  return bench::RunEachDataset(
      "bench_map_reuse", datasets, options.common,
      [&](const std::string& path, const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
        return RunDataset(path, options, vocabulary);
      });
}
