#include "privacy/density_attack.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "privacy/line_grid.h"
#include "privacy/parallel.h"
#include "privacy/scene_box.h"

namespace lcv::privacy {
namespace {

struct Sample {
  double s;         // parameter along the attacked line
  double dist_sq;   // squared distance of the neighbour (line or point) to the attacked line
};

struct VoxelStep {
  std::uint32_t voxel;
  double s_in, s_out;
};

// Annealed mean shift on weighted 1D samples with a biweight kernel of radius 3h in (s, distance):
// returns the final mode and its score at the finest bandwidth. Each level keeps only the samples
// within reach of the current mode, so later (finer) levels touch few samples.
struct Peak {
  double s = 0.0;
  double score = 0.0;
};
Peak AnnealedMeanShift(std::vector<Sample>* samples, double s_start, double h_start, int levels) {
  Peak peak{s_start, 0.0};
  double h = h_start;
  std::vector<Sample>& x = *samples;
  for (int level = 0; level < levels; ++level, h *= 0.5) {
    const double radius_sq = 9.0 * h * h;
    const double inv = 1.0 / radius_sq;
    for (int it = 0; it < 6; ++it) {
      double sw = 0.0, sws = 0.0;
      for (const Sample& q : x) {
        const double ds = q.s - peak.s;
        const double r = (ds * ds + q.dist_sq) * inv;
        if (r >= 1.0) continue;
        const double w = (1.0 - r) * (1.0 - r);
        sw += w;
        sws += w * q.s;
      }
      if (sw <= 0.0) break;
      const double next = sws / sw;
      const bool converged = std::abs(next - peak.s) < 1e-2 * h;
      peak.s = next;
      if (converged) break;
    }
    // Drop the samples the next (half as wide) levels cannot reach from near this mode.
    const double keep = 4.0 * radius_sq;
    std::size_t kept = 0;
    for (const Sample& q : x) {
      const double ds = q.s - peak.s;
      if (ds * ds + q.dist_sq < keep) x[kept++] = q;
    }
    x.resize(kept);
  }
  h *= 2.0;  // the finest bandwidth used
  const double inv = 1.0 / (9.0 * h * h);
  double score = 0.0;
  for (const Sample& q : x) {
    const double ds = q.s - peak.s;
    const double r = (ds * ds + q.dist_sq) * inv;
    if (r < 1.0) score += (1.0 - r) * (1.0 - r);
  }
  peak.score = score;
  return peak;
}

// The num_peaks highest local maxima of the (smoothed) voxel counts along a line, as parameters.
void CoarsePeaks(const std::vector<VoxelStep>& steps, const LineGrid& grid, int num_peaks,
                 std::vector<double>* smoothed, std::vector<double>* peaks_s,
                 std::vector<double>* peaks_height) {
  const std::size_t n = steps.size();
  smoothed->assign(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    // Own line removed; normalized by the chord length through the voxel so that clipped corners
    // do not look sparse.
    const double c = grid.Count(steps[k].voxel) - 1.0;
    (*smoothed)[k] = c;
  }
  std::vector<double> tmp(*smoothed);
  for (std::size_t k = 0; k < n; ++k) {
    const double left = k > 0 ? tmp[k - 1] : tmp[k];
    const double right = k + 1 < n ? tmp[k + 1] : tmp[k];
    (*smoothed)[k] = 0.25 * left + 0.5 * tmp[k] + 0.25 * right;
  }
  peaks_s->clear();
  peaks_height->clear();
  // Greedy non-maximum suppression: take the highest, suppress +-2 steps, repeat.
  std::vector<unsigned char> taken(n, 0);
  for (int p = 0; p < num_peaks; ++p) {
    double best = 0.0;
    std::size_t best_k = n;
    for (std::size_t k = 0; k < n; ++k) {
      if (!taken[k] && (*smoothed)[k] > best) {
        best = (*smoothed)[k];
        best_k = k;
      }
    }
    if (best_k == n) break;
    peaks_s->push_back(0.5 * (steps[best_k].s_in + steps[best_k].s_out));
    peaks_height->push_back(best);
    for (std::size_t k = best_k >= 2 ? best_k - 2 : 0; k <= std::min(n - 1, best_k + 2); ++k) {
      taken[k] = 1;
    }
  }
}

// Per-worker scratch, reused across lines (no allocation per line once warmed up).
struct Scratch {
  std::vector<VoxelStep> steps;
  std::vector<double> smoothed, peaks_s, peaks_height;
  std::vector<Sample> samples;
  std::vector<std::uint32_t> stamp;
  std::uint32_t stamp_value = 0;
};

// Points (estimates of other lines) bucketed in the same voxels as the line grid.
struct PointGrid {
  std::vector<std::uint32_t> offsets, entries;
};
PointGrid BuildPointGrid(const LineGrid& grid, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<unsigned char>& valid) {
  PointGrid out;
  const std::size_t nv = grid.num_voxels();
  out.offsets.assign(nv + 1, 0);
  std::vector<std::uint32_t> voxel_of(points.size(), UINT32_MAX);
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (!valid[j] || !grid.box().contains(points[j])) continue;
    const Eigen::Vector3i v = grid.VoxelOf(points[j]);
    voxel_of[j] = static_cast<std::uint32_t>(grid.Index(v.x(), v.y(), v.z()));
    ++out.offsets[voxel_of[j] + 1];
  }
  for (std::size_t v = 0; v < nv; ++v) out.offsets[v + 1] += out.offsets[v];
  out.entries.resize(out.offsets.back());
  std::vector<std::uint32_t> cursor(out.offsets.begin(), out.offsets.end() - 1);
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (voxel_of[j] != UINT32_MAX) out.entries[cursor[voxel_of[j]]++] = static_cast<std::uint32_t>(j);
  }
  return out;
}

}  // namespace

LineAttackResult RunDensityAttack(const std::vector<slam::Line3d>& lines,
                                  const std::vector<Eigen::Vector3d>& camera_centers,
                                  const DensityAttackOptions& options) {
  LineAttackResult result;
  result.name = "density";
  const std::size_t n = lines.size();
  result.Resize(n);
  for (std::size_t i = 0; i < n; ++i) result.line_ids[i] = i;
  if (n < 2) return result;

  Eigen::AlignedBox3d box = options.box;
  if (box.isEmpty()) {
    SceneBoxOptions box_options;
    box_options.num_threads = options.num_threads;
    box = EstimateSceneBox(lines, camera_centers, box_options);
  }
  if (box.isEmpty()) return result;
  const int workers = ResolveThreadCount(options.num_threads);
  const double voxel = ChooseVoxelSize(box, n, options.target_occupancy);
  const LineGrid grid(lines, box, voxel, workers);
  const int num_peaks = std::max(1, options.num_peaks);
  constexpr int kLevels = 4;  // h = voxel/2 ... voxel/16
  const double h0 = 0.5 * voxel;
  const double window = 1.5 * voxel;

  // Candidate windows per line (NaN = none), kept for the refinement rounds.
  std::vector<double> windows(n * num_peaks, std::numeric_limits<double>::quiet_NaN());
  std::vector<double> heights(n * num_peaks, 0.0);
  std::vector<Scratch> scratch(workers);

  // Collects the voxels of line i inside [lo, hi] from the traversal.
  auto window_voxels = [](const std::vector<VoxelStep>& steps, double lo, double hi,
                          auto&& visit) {
    for (const VoxelStep& st : steps) {
      if (st.s_out < lo || st.s_in > hi) continue;
      visit(st.voxel);
    }
  };

  auto choose = [&](std::size_t i, const std::array<Peak, 8>& peaks, int count) {
    int best = -1;
    double s1 = 0.0, s2 = 0.0;
    for (int k = 0; k < count; ++k) {
      if (peaks[k].score > s1) {
        s2 = s1;
        s1 = peaks[k].score;
        best = k;
      } else if (peaks[k].score > s2) {
        s2 = peaks[k].score;
      }
    }
    if (best < 0) {
      result.has_estimate[i] = 0;
      result.risk[i] = 0.0;
      return;
    }
    result.has_estimate[i] = 1;
    result.estimates[i] = lines[i].PointAt(peaks[best].s);
    result.risk[i] = s1 > 0 ? (s1 - s2) / s1 : 0.0;
  };

  // Pass 1: coarse peaks + fine line-line density.
  ParallelBlocks(n, workers, [&](std::size_t begin, std::size_t end, int w) {
    Scratch& sc = scratch[w];
    sc.stamp.assign(n, 0);
    std::array<Peak, 8> peaks;
    for (std::size_t i = begin; i < end; ++i) {
      const slam::Line3d& li = lines[i];
      double s0, s1;
      if (!ClipLineToBox(li, box, &s0, &s1)) continue;
      sc.steps.clear();
      grid.Traverse(li, s0, s1, [&](std::size_t v, double a, double b) {
        sc.steps.push_back({static_cast<std::uint32_t>(v), a, b});
      });
      CoarsePeaks(sc.steps, grid, std::min(num_peaks, 8), &sc.smoothed, &sc.peaks_s,
                  &sc.peaks_height);
      int count = 0;
      for (double sc_peak : sc.peaks_s) {
        heights[i * num_peaks + count] = sc.peaks_height[count];
        windows[i * num_peaks + count] = sc_peak;
        const double lo = sc_peak - window, hi = sc_peak + window;
        sc.samples.clear();
        if (++sc.stamp_value == 0) {
          std::fill(sc.stamp.begin(), sc.stamp.end(), 0);
          sc.stamp_value = 1;
        }
        sc.stamp[i] = sc.stamp_value;
        window_voxels(sc.steps, lo, hi, [&](std::uint32_t v) {
          for (const std::uint32_t* it = grid.LinesBegin(v); it != grid.LinesEnd(v); ++it) {
            const std::uint32_t j = *it;
            if (sc.stamp[j] == sc.stamp_value) continue;
            sc.stamp[j] = sc.stamp_value;
            const slam::Line3d& lj = lines[j];
            const double c = li.direction.dot(lj.direction);
            const double denom = 1.0 - c * c;
            if (denom < 1e-12) continue;
            const Eigen::Vector3d wv = li.anchor - lj.anchor;
            const double da = li.direction.dot(wv);
            const double db = lj.direction.dot(wv);
            const double si = (c * db - da) / denom;
            if (si < lo || si > hi) continue;
            const double sj = (db - c * da) / denom;
            const double dist_sq = (wv + si * li.direction - sj * lj.direction).squaredNorm();
            if (dist_sq > voxel * voxel) continue;
            sc.samples.push_back({si, dist_sq});
          }
        });
        peaks[count] = AnnealedMeanShift(&sc.samples, sc_peak, h0, kLevels);
        // Keep the peak inside its window (mean shift may drift to a neighbour's peak).
        if (peaks[count].s < lo || peaks[count].s > hi) peaks[count].s = sc_peak;
        // Windows compete by their coarse line density: measured on the synthetic street it
        // picks the right surface crossing more often than the fine score (which mostly
        // reflects the local point spacing), see docs/audit.md.
        peaks[count].score = sc.peaks_height[count];
        ++count;
      }
      choose(i, peaks, count);
    }
  });

  // Refinement: neighbours from the current estimates.
  for (int round = 0; round < options.iterations; ++round) {
    const PointGrid points = BuildPointGrid(grid, result.estimates, result.has_estimate);
    const std::vector<Eigen::Vector3d> estimates = result.estimates;
    ParallelBlocks(n, workers, [&](std::size_t begin, std::size_t end, int w) {
      Scratch& sc = scratch[w];
      std::array<Peak, 8> peaks;
      const double max_dist_sq = h0 * h0;
      for (std::size_t i = begin; i < end; ++i) {
        const slam::Line3d& li = lines[i];
        double s0, s1;
        if (!ClipLineToBox(li, box, &s0, &s1)) continue;
        sc.steps.clear();
        grid.Traverse(li, s0, s1, [&](std::size_t v, double a, double b) {
          sc.steps.push_back({static_cast<std::uint32_t>(v), a, b});
        });
        int count = 0;
        for (int k = 0; k < num_peaks && k < 8; ++k) {
          const double centre = windows[i * num_peaks + k];
          if (std::isnan(centre)) break;
          const double lo = centre - window, hi = centre + window;
          sc.samples.clear();
          window_voxels(sc.steps, lo, hi, [&](std::uint32_t v) {
            for (std::uint32_t e = points.offsets[v]; e < points.offsets[v + 1]; ++e) {
              const std::uint32_t j = points.entries[e];
              if (j == i) continue;
              // j is a neighbour if its current estimate is near L_i inside the window; the
              // sample is then the closest point of L_i to the line L_j itself.
              const Eigen::Vector3d rel = estimates[j] - li.anchor;
              const double s = li.direction.dot(rel);
              if (s < lo || s > hi) continue;
              if (rel.squaredNorm() - s * s > max_dist_sq) continue;
              const slam::Line3d& lj = lines[j];
              const double c = li.direction.dot(lj.direction);
              const double denom = 1.0 - c * c;
              if (denom < 1e-12) continue;
              const Eigen::Vector3d wv = li.anchor - lj.anchor;
              const double da = li.direction.dot(wv);
              const double db = lj.direction.dot(wv);
              const double si = (c * db - da) / denom;
              if (si < lo || si > hi) continue;
              const double sj = (db - c * da) / denom;
              sc.samples.push_back(
                  {si, (wv + si * li.direction - sj * lj.direction).squaredNorm()});
            }
          });
          const double start = result.has_estimate[i] &&
                                       std::abs(li.Parameter(estimates[i]) - centre) <= window
                                   ? li.Parameter(estimates[i])
                                   : centre;
          const bool supported = !sc.samples.empty();
          peaks[count] = AnnealedMeanShift(&sc.samples, start, h0, kLevels);
          if (!supported || peaks[count].s < lo || peaks[count].s > hi) peaks[count].s = start;
          peaks[count].score = heights[i * num_peaks + k];
          ++count;
        }
        if (count > 0) choose(i, peaks, count);
      }
    });
  }
  return result;
}

LineAttackResult RunDensityAttack(const slam::Map& map, const DensityAttackOptions& options) {
  std::vector<slam::Line3d> lines;
  std::vector<slam::Id> ids;
  lines.reserve(map.lines.size());
  for (const auto& [id, l] : map.lines) {
    lines.push_back(l.line);
    ids.push_back(id);
  }
  std::vector<Eigen::Vector3d> centers;
  for (const auto& [id, kf] : map.server_keyframes) centers.push_back(kf.cam_from_world.Center());
  for (const auto& [id, kf] : map.keyframes) centers.push_back(kf.cam_from_world.Center());
  LineAttackResult result = RunDensityAttack(lines, centers, options);
  result.line_ids = ids;
  return result;
}

}  // namespace lcv::privacy
