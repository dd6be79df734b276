#include "apps/slam_timing_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

namespace lcv::apps {
namespace {

using nlohmann::json;

// The stages of slam::TrackingStageTimes, by their names in the stats file.
std::vector<std::pair<const char*, double slam::TrackingStageTimes::*>> Stages() {
  return {{"handover", &slam::TrackingStageTimes::handover_ms},
          {"initializer", &slam::TrackingStageTimes::initializer_ms},
          {"initialization_frames", &slam::TrackingStageTimes::initialization_frames_ms},
          {"motion", &slam::TrackingStageTimes::motion_ms},
          {"recovery", &slam::TrackingStageTimes::recovery_ms},
          {"relocalization", &slam::TrackingStageTimes::relocalization_ms},
          {"two_view", &slam::TrackingStageTimes::two_view_ms},
          {"local_map", &slam::TrackingStageTimes::local_map_ms},
          {"keyframe_decision", &slam::TrackingStageTimes::keyframe_decision_ms}};
}

}  // namespace

Summary Summarize(std::vector<double> values) {
  Summary s;
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  s.median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  // Nearest-rank percentiles.
  auto percentile = [&](double p) {
    return values[std::min(n - 1, static_cast<size_t>(std::ceil(p * n)) - 1)];
  };
  s.p90 = percentile(0.90);
  s.p95 = percentile(0.95);
  s.p99 = percentile(0.99);
  s.max = values.back();
  return s;
}

json SummaryJson(const Summary& s) {
  return json{{"median", s.median}, {"mean", s.mean}, {"p90", s.p90}, {"p95", s.p95},
              {"p99", s.p99}, {"max", s.max}};
}

json LockJson(const slam::LockHoldSummary& s) {
  return json{{"max", s.max_ms}, {"p99", s.p99_ms}, {"count", s.count}};
}

json FrameTimingJson(const slam::FrameResult& result) {
  json stages = json::object();
  for (const auto& [name, member] : Stages()) stages[name] = result.stages.*member;
  return json{{"tracking_ms", result.tracking_ms},
              {"extraction_ms", result.extraction_ms},
              {"tracking_cpu_ms", result.tracking_cpu_ms},
              {"preemptions", result.preemptions},
              {"mapping_ms", result.mapping_ms},
              {"stages_ms", std::move(stages)}};
}

json TrackingTimingJson(const std::vector<slam::FrameResult>& results) {
  std::vector<double> cpu_ms;
  long preemptions = 0;
  for (const slam::FrameResult& r : results) {
    cpu_ms.push_back(r.tracking_cpu_ms);
    preemptions += r.preemptions;
  }
  json stages = json::object();
  for (const auto& [name, member] : Stages()) {
    // Over the frames that ran the stage (a stage most frames skip would have a median of 0).
    std::vector<double> ms;
    for (const slam::FrameResult& r : results) {
      if (r.stages.*member > 0.0) ms.push_back(r.stages.*member);
    }
    json summary = SummaryJson(Summarize(ms));
    summary["frames"] = ms.size();
    stages[name] = std::move(summary);
  }
  return json{{"tracking_cpu_ms", SummaryJson(Summarize(cpu_ms))},
              {"preemptions", preemptions},
              {"stages_ms", std::move(stages)}};
}

}  // namespace lcv::apps
