#pragma once
// Readers of the concealed regions for check 3 (formats documented in docs/audit.md).
//
// REGIONS.json:
//   {"regions": [{"name": "laptop", "min": [x, y, z], "max": [x, y, z]}, ...],
//    "line_ids": [17, 42]}            (both keys optional, at least one present)
// scene.json (written by `lcv synth`): every object missing from one of the two sequences
// ("in_map": false or "in_client": false) becomes a region named after it, from its box:
//   {"objects": [{"name": "laptop", "bbox_min": [..], "bbox_max": [..],
//                 "in_map": true, "in_client": false}, ...]}
// Other keys are ignored. Coordinates are in the maps' world frame.
// Bad files throw lcv::InputError naming the file and the JSON pointer of the problem.

#include <string>

#include "privacy/concealed_check.h"

namespace lcv::privacy {

ConcealedSpec ReadConcealedRegions(const std::string& path);
ConcealedSpec ReadSceneConcealedRegions(const std::string& path);

// From text (source_name used in messages); for tests and the readers above.
ConcealedSpec ParseConcealedRegions(const std::string& text, const std::string& source_name);
ConcealedSpec ParseSceneConcealedRegions(const std::string& text, const std::string& source_name);

}  // namespace lcv::privacy
