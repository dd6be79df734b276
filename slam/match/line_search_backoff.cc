#include "slam/match/line_search_backoff.h"

#include <algorithm>

namespace lcv::slam {

int LineSearchBackoff::PeriodOfMisses(int misses) const {
  if (!enabled() || misses < options_.misses) return 1;
  const int doublings = std::min(misses / options_.misses, 30);
  return static_cast<int>(std::min<std::int64_t>(options_.max_period, std::int64_t{1} << doublings));
}

int LineSearchBackoff::Period(Id line_id) const {
  const auto it = misses_.find(line_id);
  return it == misses_.end() ? 1 : PeriodOfMisses(it->second);
}

bool LineSearchBackoff::ShouldSearch(Id line_id) const {
  const int period = Period(line_id);
  return period <= 1 || (frame_ + line_id) % static_cast<std::uint64_t>(period) == 0;
}

void LineSearchBackoff::Record(Id line_id, bool searched_in_image, bool matched) {
  if (!enabled()) return;
  if (matched) {
    misses_.erase(line_id);
  } else if (searched_in_image) {
    int& misses = misses_[line_id];
    misses = std::min(misses + 1, 1 << 20);
  }
}

}  // namespace lcv::slam
