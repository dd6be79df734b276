#pragma once
// `lcv slam --stats-out`: summaries of per-frame values and the tracking thread's timing
// (issue 14: where tracking's time goes, per frame and per stage; docs/slam.md "lcv slam").

#include <vector>

#include <nlohmann/json.hpp>

#include "slam/frame_result.h"
#include "slam/util/lock_timing.h"

namespace lcv::apps {

// Median, mean and nearest-rank percentiles of a sample (all 0 when empty).
struct Summary {
  double median = 0, mean = 0, p90 = 0, p95 = 0, p99 = 0, max = 0;
};
Summary Summarize(std::vector<double> values);
nlohmann::json SummaryJson(const Summary& s);  // {median, mean, p90, p95, p99, max}
nlohmann::json LockJson(const slam::LockHoldSummary& s);  // {max, p99, count}

// One frame's timing for per_frame: tracking_ms, extraction_ms, tracking_cpu_ms, preemptions,
// mapping_ms and stages_ms {handover, initializer, initialization_frames, motion, recovery,
// relocalization, local_map, keyframe_decision} (ms).
nlohmann::json FrameTimingJson(const slam::FrameResult& result);

// Over all frames: tracking_cpu_ms {median, ..., max}, preemptions (total) and stages_ms
// {stage: {median, ..., max, frames (that ran it)}}.
nlohmann::json TrackingTimingJson(const std::vector<slam::FrameResult>& results);

}  // namespace lcv::apps
