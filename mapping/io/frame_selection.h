#pragma once
// Frame selection over a sequence of frames: one or more comma-separated slices
// `START:END:STEP`, each with Python slice semantics for non-negative bounds (frames START,
// START+STEP, ... below END, exclusive). Every part of a slice may be empty: START defaults to
// 0, END to the end of the sequence, STEP to 1. Several slices select their union, in frame
// order, each frame once. Examples:
//   ":"      every frame            "1::2"   odd frames (the paper's map half on KITTI)
//   "0::2"   even frames (client)   "100:200" frames 100..199
//   "0:24:2,80::2"  the even frames without 24..79 (a camera interrupted for 5.6 s on KITTI)
// Indices refer to the whole sequence (frame numbers), before any other filtering.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace lcv::mapping {

// One slice START:END:STEP.
struct FrameSlice {
  std::size_t start = 0;
  std::optional<std::size_t> end;  // exclusive; empty = to the end
  std::size_t step = 1;            // >= 1

  // The selected indices among 0..count-1, increasing (empty when start >= count).
  std::vector<std::size_t> Apply(std::size_t count) const;
  // Canonical text ("1::2"; "0:100:1" is printed "0:100").
  std::string ToString() const;
};

struct FrameSelection {
  std::vector<FrameSlice> slices{FrameSlice{}};  // never empty; the default selects every frame

  // Parses "START:END:STEP" (or "START:END", or ":"), or several of them separated by commas.
  // Returns empty and sets *error (when given) to what is wrong ("step must be >= 1", "'x' is
  // not a non-negative integer") on bad text; a lone number is rejected as ambiguous.
  static std::optional<FrameSelection> Parse(const std::string& text, std::string* error = nullptr);

  // The selected indices among 0..count-1: the union of the slices', increasing, each once.
  std::vector<std::size_t> Apply(std::size_t count) const;
  // True when every frame of any sequence is selected.
  bool SelectsAll() const;
  // Canonical text, parseable by Parse (the slices' texts joined by commas).
  std::string ToString() const;
};

}  // namespace lcv::mapping
