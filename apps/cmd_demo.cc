// `lcv demo`: the main job on built-in data, end to end, as far as the project goes today:
//   1. a built-in synthetic street point map with ground truth (mapping/synthetic_map.h);
//   2. published as a line cloud (random directions, re-drawn anchors, observations dropped);
//   3. both written as map files, read back and validated;
//   4. a check that what was read back is a publishable line cloud.
// Results go to --out (default ./lcv-demo); a short summary goes to stdout.

#include <sys/stat.h>

#include <chrono>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

void MakeDirectory(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
    throw InputError(path, "cannot create folder");
  }
}

int RunDemo(int argc, char** argv) {
  ArgParser args("lcv demo [--out DIR] [--seed N]",
                 "Runs the main job on built-in synthetic data: a street point map with ground "
                 "truth is\npublished as a line cloud, written, read back, checked and summarized.",
                 "lcv demo --out /tmp/lcv-demo");
  args.AddOption("--out", "DIR", "folder for the results", "lcv-demo");
  args.AddOption("--seed", "N", "seed of the scene and of the line directions", "1");
  args.AddOption("--points", "N", "number of points in the built-in map", "3000");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string out = args.Get("--out");
  const std::uint64_t seed = args.GetSeed();
  MakeDirectory(out);

  const auto start = std::chrono::steady_clock::now();
  std::cerr << "[demo 1/3] building the synthetic street point map\n";
  mapping::SyntheticMapOptions scene;
  scene.seed = seed;
  scene.num_points = args.GetInt("--points");
  if (auto problem = scene.Problem()) throw UsageError("--points: " + *problem);
  const slam::Map point_map = mapping::MakeSyntheticPointMap(scene);
  const std::string point_map_path = out + "/points.lcmap";
  mapping::WriteMap(point_map, point_map_path);

  std::cerr << "[demo 2/3] publishing it as a line cloud\n";
  mapping::LineCloudOptions publish;
  publish.seed = seed;
  const slam::Map line_cloud = mapping::ConvertToLineCloud(point_map, publish);
  const std::string line_cloud_path = out + "/line_cloud.lcmap";
  mapping::WriteMap(line_cloud, line_cloud_path);
  mapping::WriteMap(line_cloud, out + "/line_cloud.json");

  std::cerr << "[demo 3/3] reading back and checking\n";
  const slam::Map reread = mapping::ReadMap(line_cloud_path);
  const bool published = slam::IsPublishedLineCloud(reread);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::cout << "point map:   " << point_map.keyframes.size() << " keyframes, "
            << point_map.points.size() << " points -> " << point_map_path << "\n";
  std::cout << "line cloud:  " << reread.server_keyframes.size() << " server keyframes, "
            << reread.lines.size() << " lines -> " << line_cloud_path << "\n";
  std::cout << "published:   " << (published ? "yes" : "NO") << " (no keyframes, points or X')\n";
  std::cout << "time:        " << std::fixed << std::setprecision(2) << seconds << " s\n";
  return published ? kExitOk : kExitCheckFailed;
}

}  // namespace
LCV_REGISTER_COMMAND("demo", "run the main job on built-in synthetic data", RunDemo);
}  // namespace lcv::apps
