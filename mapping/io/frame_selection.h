#pragma once
// Frame selection `START:END:STEP` over a sequence of frames, with Python slice semantics for
// non-negative bounds: frames START, START+STEP, ... below END (exclusive). Every part may be
// empty: START defaults to 0, END to the end of the sequence, STEP to 1. Examples:
//   ":"      every frame            "1::2"   odd frames (the paper's map half on KITTI)
//   "0::2"   even frames (client)   "100:200" frames 100..199
// Indices refer to the whole sequence (frame numbers), before any other filtering.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace lcv::mapping {

struct FrameSelection {
  std::size_t start = 0;
  std::optional<std::size_t> end;  // exclusive; empty = to the end
  std::size_t step = 1;            // >= 1

  // Parses "START:END:STEP" (or "START:END", or ":"). Returns empty and sets *error (when
  // given) to what is wrong ("step must be >= 1", "'x' is not a non-negative integer") on bad
  // text; a lone number is rejected as ambiguous.
  static std::optional<FrameSelection> Parse(const std::string& text, std::string* error = nullptr);

  // The selected indices among 0..count-1, increasing (empty when start >= count).
  std::vector<std::size_t> Apply(std::size_t count) const;
  // True when every frame of any sequence is selected.
  bool SelectsAll() const { return start == 0 && !end && step == 1; }
  // Canonical text, parseable by Parse ("1::2", "0:100:1" is printed "0:100").
  std::string ToString() const;
};

}  // namespace lcv::mapping
