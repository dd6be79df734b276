#pragma once
#include <cstdint>
#include <limits>

namespace lcv::slam {

// Identifiers of keyframes, landmarks, cameras. Ids are stable across save/load and never reused
// within one map; containers refer to each other by id, never by pointer (STYLE.md 5).
using Id = std::uint64_t;
inline constexpr Id kInvalidId = std::numeric_limits<Id>::max();

}  // namespace lcv::slam
