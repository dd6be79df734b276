#include "mapping/io/frame_selection.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>

namespace lcv::mapping {
namespace {

// Parses a non-negative integer; empty text gives fallback.
bool ParseIndex(const std::string& text, std::optional<std::size_t>* out, std::string* error) {
  if (text.empty()) {
    out->reset();
    return true;
  }
  bool digits = true;
  for (const char c : text) digits &= c >= '0' && c <= '9';
  errno = 0;
  const unsigned long long value = digits ? std::strtoull(text.c_str(), nullptr, 10) : 0;
  if (!digits || errno != 0) {
    if (error) *error = "'" + text + "' is not a non-negative integer";
    return false;
  }
  *out = static_cast<std::size_t>(value);
  return true;
}

// Parses one slice "START:END:STEP" (text has no comma).
std::optional<FrameSlice> ParseSlice(const std::string& text, std::string* error) {
  std::vector<std::string> parts(1);
  for (const char c : text) {
    if (c == ':') {
      parts.emplace_back();
    } else if (c != ' ') {
      parts.back() += c;
    }
  }
  if (parts.size() == 1 || parts.size() > 3) {
    if (error) {
      *error = "'" + text + "': expected START:END or START:END:STEP (e.g. 1::2 for odd frames)";
    }
    return std::nullopt;
  }
  std::optional<std::size_t> start, end, step;
  if (!ParseIndex(parts[0], &start, error) || !ParseIndex(parts[1], &end, error)) {
    return std::nullopt;
  }
  if (parts.size() == 3 && !ParseIndex(parts[2], &step, error)) return std::nullopt;
  if (step && *step == 0) {
    if (error) *error = "'" + text + "': step must be >= 1";
    return std::nullopt;
  }
  FrameSlice slice;
  slice.start = start.value_or(0);
  slice.end = end;
  slice.step = step.value_or(1);
  return slice;
}

}  // namespace

std::vector<std::size_t> FrameSlice::Apply(std::size_t count) const {
  std::vector<std::size_t> indices;
  const std::size_t stop = end ? std::min(*end, count) : count;
  for (std::size_t i = start; i < stop; i += step) indices.push_back(i);
  return indices;
}

std::string FrameSlice::ToString() const {
  std::string text = std::to_string(start) + ":" + (end ? std::to_string(*end) : "");
  if (step != 1) text += ":" + std::to_string(step);
  return text;
}

std::optional<FrameSelection> FrameSelection::Parse(const std::string& text, std::string* error) {
  FrameSelection selection;
  selection.slices.clear();
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = text.find(',', begin);
    const std::string part = text.substr(begin, comma == std::string::npos ? std::string::npos
                                                                             : comma - begin);
    const std::optional<FrameSlice> slice = ParseSlice(part, error);
    if (!slice) return std::nullopt;
    selection.slices.push_back(*slice);
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return selection;
}

std::vector<std::size_t> FrameSelection::Apply(std::size_t count) const {
  std::vector<bool> selected(count, false);
  for (const FrameSlice& slice : slices) {
    for (const std::size_t i : slice.Apply(count)) selected[i] = true;
  }
  std::vector<std::size_t> indices;
  for (std::size_t i = 0; i < count; ++i) {
    if (selected[i]) indices.push_back(i);
  }
  return indices;
}

bool FrameSelection::SelectsAll() const {
  for (const FrameSlice& slice : slices) {
    if (slice.start == 0 && !slice.end && slice.step == 1) return true;
  }
  return false;
}

std::string FrameSelection::ToString() const {
  std::string text;
  for (const FrameSlice& slice : slices) text += (text.empty() ? "" : ",") + slice.ToString();
  return text;
}

}  // namespace lcv::mapping
