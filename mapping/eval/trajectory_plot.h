#pragma once
// A plot of an estimated trajectory over its ground truth, as evo's `evo_ape --plot` draws it:
// the two trajectories seen from above a plane of the world, the ground truth a grey dashed
// line, the estimate coloured by its error (viridis, from the smallest error to the largest)
// with a colour bar, a grid in metres with equal scales on both axes, and a title.
//
// Input is what trajectory_error.h computes: the centres of the associated poses, in the ground
// truth's frame (the estimate after its alignment), and one error per pose. The whole ground
// truth may be given too, so that the part the estimate never reached still shows.
//
// Drawn with OpenCV's imgproc only (no display, no encoder): the caller writes the image, e.g.
// as a PNG with mapping::EncodePng (mapping/io/media.h). Same input, same pixels.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace lcv::mapping {

struct TrajectoryPlotData {
  // The ground truth's whole path (every pose, in file order); may be empty.
  std::vector<Eigen::Vector3d> reference_path;
  // Associated entries, in time order: ground-truth centre, estimated centre, error. The three
  // have the same size (TrajectoryErrorReport's gt_centres, est_centres, translation_errors).
  std::vector<Eigen::Vector3d> gt_centres;
  std::vector<Eigen::Vector3d> est_centres;
  std::vector<double> errors;
};

struct TrajectoryPlotOptions {
  int width = 1000;   // pixels, >= 320
  int height = 800;   // pixels, >= 320
  // World axes drawn to the right and upward (0 x, 1 y, 2 z). Unset: the two axes along which
  // the ground truth (and the estimate) spread most, in the order x, y, z.
  std::optional<std::array<int, 2>> axes;
  std::string title;               // first line at the top
  std::string error_label = "m";   // above the colour bar, e.g. "APE m"
};

// "xy", "xz", "yx", "yz", "zx", "zy"; nullopt for anything else.
std::optional<std::array<int, 2>> ParsePlotAxes(const std::string& name);

// Where a world point lands in the plot (for tests and annotations).
struct TrajectoryPlotLayout {
  std::array<int, 2> axes{0, 1};
  double pixels_per_metre = 1.0;
  Eigen::Vector2d origin_px = Eigen::Vector2d::Zero();  // pixel of the world point 0 on the axes
  Eigen::Vector2d ToPixel(const Eigen::Vector3d& world) const {
    return {origin_px.x() + pixels_per_metre * world[axes[0]],
            origin_px.y() - pixels_per_metre * world[axes[1]]};
  }
};

// The plot as an 8-bit BGR image of options' size. Precondition (checked): data's three
// entry vectors have the same size, options' size within the bounds above. An empty input
// gives the frame, the title and an empty grid.
cv::Mat PlotTrajectoryErrors(const TrajectoryPlotData& data, const TrajectoryPlotOptions& options,
                             TrajectoryPlotLayout* layout = nullptr);

// The colour PlotTrajectoryErrors gives an error at `fraction` (0 the smallest, 1 the largest)
// of the colour bar's range, BGR.
cv::Vec3b TrajectoryPlotColour(double fraction);

}  // namespace lcv::mapping
