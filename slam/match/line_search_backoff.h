#pragma once
// Which lines of the line cloud the tracking thread searches in a frame (Tracker::MatchLocalLines
// with MatchLinesByProjection): a line whose samples were searched inside the image on several
// frames in a row without a match is searched less and less often, on one frame in 2, 4, ...
// up to max_period, until it matches again.
//
// Why: a line's search costs its samples (~20 windows for a 360-degree camera, 200 at most)
// whether or not its hidden point is in view. Most lines of the tracking window that have no X'
// yet are lines the client cannot match there (the hidden point occluded on the client's path,
// seen by the server from directions the client never takes, or its corner not detected): on
// the equirectangular overlap pairs, 300 of them per frame gave 1-10 matches, and the line
// search was the largest part of the line client's extra time over the point client (0.67 of
// ~0.95 ms a frame in the local-map stage; docs/benchmarks-lcvslam.md "Line search back-off").
// A line that becomes matchable is searched again within max_period frames; tracking holds
// meanwhile on its points and X'. The tracking counterpart of
// ORB-SLAM's found / visible ratio, which culls such points from the map: a line of the server
// cannot be culled, so the client stops looking for it instead.
//
//   LineSearchBackoff backoff(options);            // one per tracking thread
//   backoff.StartFrame();
//   for (line : window) if (backoff.ShouldSearch(line.id)) candidates.push_back(line);
//   ... MatchLinesByProjection(candidates, ...) ...
//   for (c : candidates) backoff.Record(c.line_id, searched_in_image(c), matched(c));
//
// Searches are staggered by line id, so that a frame searches about the same share of the
// backed-off lines as the next. A line that was outside the image (no sample searched) is not
// evidence against it: its count stays.
//
// Thread safety: none; one object per tracking thread. Memory: one entry per line that missed.

#include <cstdint>
#include <unordered_map>

#include "slam/util/ids.h"

namespace lcv::slam {

struct LineSearchBackoffOptions {
  // Misses in a row (searched in the image, no match) per doubling of the period: a line is
  // searched on every frame until `misses` misses, then on one frame in 2, after 2 * misses
  // misses one in 4, and so on. 0 (the library's default): every line on every frame.
  //
  // `lcv slam` sets 2 for an equirectangular camera and 0 for the others (apps::
  // ApplyCameraDefaults), from issue 11's 18 overlap pairs (docs/benchmarks-lcvslam.md "Line
  // search back-off"): with 2 the 360-degree client's APE against the point client went 1.05x ->
  // 0.91x and its local-map stage 0.25-0.3 ms faster, but the perspective client's went 0.93x ->
  // 1.10x and the fisheye one's 0.91x -> 1.05x. A 360-degree camera images each line's whole
  // interval on every frame, so a miss says the hidden point was searched and not found. A
  // narrower camera counts misses while a line is partly in view and its hidden point may still
  // be outside the image, and then searches it late when the point comes into view.
  int misses = 0;
  // The longest period (frames); 1 disables the back-off. 4 frames at 10 Hz: a line that comes
  // into view where its hidden point can be matched is searched again within 0.4 s. Measured
  // on the six 360-degree overlap pairs (docs/benchmarks-lcvslam.md "Line search back-off"):
  // misses 2 / max_period 4 and misses 1 / max_period 8 save about the same time (0.25-0.3 ms
  // of the local-map stage), APE geometric mean against the point client 0.91x and 0.94x
  // (without the back-off 1.05x); the shorter period is kept, as it waits less for a line that
  // comes into view (a forward camera's lines enter from the image's side).
  int max_period = 4;
};

class LineSearchBackoff {
 public:
  explicit LineSearchBackoff(const LineSearchBackoffOptions& options = LineSearchBackoffOptions())
      : options_(options) {}

  bool enabled() const { return options_.misses > 0 && options_.max_period > 1; }
  // Begins a frame's search (the frames its lines' periods count).
  void StartFrame() { ++frame_; }
  // Whether the line is searched in the current frame.
  bool ShouldSearch(Id line_id) const;
  // The line's period now: 1 (every frame) up to max_period.
  int Period(Id line_id) const;
  // After a frame's search of the line: searched_in_image, a sample of it was searched inside
  // the image; matched, it got a keypoint. A match forgets the line's misses.
  void Record(Id line_id, bool searched_in_image, bool matched);
  // Forgets every line (a new map).
  void Clear() { misses_.clear(); }
  int num_lines_missing() const { return static_cast<int>(misses_.size()); }

 private:
  int PeriodOfMisses(int misses) const;

  LineSearchBackoffOptions options_;
  std::unordered_map<Id, int> misses_;  // misses in a row, per line that has any
  std::uint64_t frame_ = 0;
};

}  // namespace lcv::slam
