#pragma once
// The YAML subset that camera and settings files use, parsed into a JSON tree so that YAML and
// JSON files go through the same validation code.
//
// Supported (enough for stella_vslam / ORB-SLAM settings, EuRoC sensor.yaml and OpenCV-written
// YAML files):
// - block mappings `key: value` nested by indentation (spaces only), block sequences `- item`
//   (also `- key: value` items), flow sequences `[a, b]` and mappings `{a: 1}` (which may span
//   several lines);
// - scalars: "double" and 'single' quoted strings, plain strings, integers, decimals
//   (1e-3, -0.5), true/false, null/~;
// - `#` comments, directives (`%YAML:1.0`, `%YAML 1.2`), `---` / `...` document markers, and
//   tags (`!!opencv-matrix`, ignored).
// Not supported: anchors/aliases, multi-line plain or block scalars (`|`, `>`), complex keys,
// several documents. They are reported as errors, never silently misread.

#include <string>

#include <nlohmann/json_fwd.hpp>

namespace lcv::mapping {

// Parses text; an empty document gives null. Duplicate keys, bad indentation, tabs in
// indentation, unclosed brackets or quotes throw lcv::InputError("<source_name>: line N: what").
nlohmann::json ParseYamlSubset(const std::string& text, const std::string& source_name);

}  // namespace lcv::mapping
