// ORB extraction timing (not run by ctest): OrbExtractor on KITTI 00 frames resized to 640 px
// wide (640x194) and, to match the 640x360 target, on the same frames scaled to 640x360; with
// cv::ORB detect+compute as the reference. Prints the median and p90 of the thread CPU time per
// configuration (and the wall-time median), single-threaded (cv::setNumThreads(1)).
//
//   build/bench_feature [DIR=../shared/data/kitti00] [FRAMES=60]
// DIR may also be a sequence written by `lcv synth` (DIR/images/NNNNNN.png, used unresized).

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/feature/orb_extractor.h"

namespace {

struct Stats {
  double median_ms = 0, p90_ms = 0;
};

Stats Summarize(std::vector<double> times) {
  std::sort(times.begin(), times.end());
  Stats s;
  if (times.empty()) return s;
  s.median_ms = times[times.size() / 2];
  s.p90_ms = times[std::min(times.size() - 1, times.size() * 9 / 10)];
  return s;
}

// Thread CPU time, ms: unlike wall time it does not grow when other processes share the
// cores (the benchmark machine often runs builds in parallel). Wall time is printed too.
double Now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double WallNow() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  const std::string dir = argc > 1 ? argv[1] : std::string("../shared/data/kitti00");
  const int frames = argc > 2 ? std::stoi(argv[2]) : 60;
  std::vector<cv::Mat> wide, tall;
  // A sequence of `lcv synth` (DIR/images/NNNNNN.png) is used at its own size.
  const bool synthetic_layout = std::filesystem::is_directory(dir + "/images");
  for (int i = 0; i < frames; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), synthetic_layout ? "/images/%06d.png" : "/image_0/%06d.png",
                  i);
    if (!std::filesystem::exists(dir + name)) break;
    const cv::Mat image = cv::imread(dir + name, cv::IMREAD_GRAYSCALE);
    if (image.empty()) break;
    if (synthetic_layout) {
      wide.push_back(image);
      tall.push_back(image);
      continue;
    }
    cv::Mat a, b;
    cv::resize(image, a, cv::Size(640, image.rows * 640 / image.cols), 0, 0, cv::INTER_AREA);
    cv::resize(image, b, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
    wide.push_back(a);
    tall.push_back(b);
  }
  if (wide.empty()) {
    std::fprintf(stderr, "bench_feature: no images in %s/image_0 or %s/images\n", dir.c_str(),
                 dir.c_str());
    return 1;
  }
  std::printf("bench_feature: %zu frames from %s\n", wide.size(), dir.c_str());
  std::printf("%-34s %8s %10s %10s %10s\n", "configuration", "kpts", "median_ms", "p90_ms",
              "wall_med");
  const bool synthetic = wide.front().size() == tall.front().size();
  for (const auto* set : {&wide, &tall}) {
    if (synthetic && set == &tall) break;  // one size only
    const cv::Size size = set->front().size();
    for (int features : {1000, 2000}) {
      lcv::slam::OrbExtractorOptions options;
      options.num_features = features;
      lcv::slam::OrbExtractor extractor(options);
      std::vector<lcv::slam::Keypoint> keypoints;
      std::vector<lcv::slam::OrbDescriptor> descriptors;
      std::vector<double> times, wall;
      double total_keypoints = 0;
      extractor.Extract(set->front(), cv::Mat(), &keypoints, &descriptors);  // warm-up
      for (const cv::Mat& image : *set) {
        const double start = Now(), wall_start = WallNow();
        extractor.Extract(image, cv::Mat(), &keypoints, &descriptors);
        times.push_back(Now() - start);
        wall.push_back(WallNow() - wall_start);
        total_keypoints += keypoints.size();
      }
      const Stats s = Summarize(times);
      char label[64];
      std::snprintf(label, sizeof(label), "OrbExtractor %dx%d n=%d", size.width, size.height,
                    features);
      std::printf("%-34s %8.0f %10.2f %10.2f %10.2f\n", label, total_keypoints / set->size(),
                  s.median_ms, s.p90_ms, Summarize(wall).median_ms);

      cv::Ptr<cv::ORB> orb = cv::ORB::create(features);
      std::vector<cv::KeyPoint> cv_keypoints;
      cv::Mat cv_descriptors;
      times.clear();
      wall.clear();
      total_keypoints = 0;
      for (const cv::Mat& image : *set) {
        const double start = Now(), wall_start = WallNow();
        orb->detectAndCompute(image, cv::noArray(), cv_keypoints, cv_descriptors);
        times.push_back(Now() - start);
        wall.push_back(WallNow() - wall_start);
        total_keypoints += cv_keypoints.size();
      }
      const Stats r = Summarize(times);
      std::snprintf(label, sizeof(label), "cv::ORB      %dx%d n=%d", size.width, size.height,
                    features);
      std::printf("%-34s %8.0f %10.2f %10.2f %10.2f\n", label, total_keypoints / set->size(),
                  r.median_ms, r.p90_ms, Summarize(wall).median_ms);
    }
  }
  return 0;
}
