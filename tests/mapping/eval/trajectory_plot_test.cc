#include "mapping/eval/trajectory_plot.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "mapping/eval/trajectory_error.h"
#include "slam/geometry/so3.h"

namespace lcv::mapping {
namespace {

// The smallest distance (sum of channel differences) between `colour` and a pixel within
// `radius` of `at`.
int ClosestColourDistance(const cv::Mat& image, const Eigen::Vector2d& at, const cv::Vec3b& colour,
                          int radius = 1) {
  int best = std::numeric_limits<int>::max();
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int x = static_cast<int>(std::lround(at.x())) + dx;
      const int y = static_cast<int>(std::lround(at.y())) + dy;
      if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      int d = 0;
      for (int c = 0; c < 3; ++c) d += std::abs(p[c] - colour[c]);
      best = std::min(best, d);
    }
  }
  return best;
}

// A street along x (ground truth at y = 0, z = 1.5) and an estimate 1 m to its side whose
// error grows from 0 to 2 m along it.
TrajectoryPlotData Street() {
  TrajectoryPlotData data;
  for (int i = 0; i <= 40; ++i) {
    const Eigen::Vector3d gt(0.5 * i, 0.0, 1.5);
    data.reference_path.push_back(gt);
    data.gt_centres.push_back(gt);
    data.est_centres.push_back(gt + Eigen::Vector3d(0.0, 1.0, 0.0));
    data.errors.push_back(0.05 * i);
  }
  return data;
}

TEST(TrajectoryPlot, ParsesAxes) {
  EXPECT_EQ(ParsePlotAxes("xy"), (std::array<int, 2>{0, 1}));
  EXPECT_EQ(ParsePlotAxes("zx"), (std::array<int, 2>{2, 0}));
  for (const char* bad : {"", "x", "xx", "xa", "xyz", "XY"}) {
    EXPECT_FALSE(ParsePlotAxes(bad)) << bad;
  }
}

TEST(TrajectoryPlot, ChoosesThePlaneTheTrajectorySpreadsIn) {
  // KITTI's convention: the car drives in x-z, y points down and hardly changes.
  TrajectoryPlotData data;
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector3d c(10.0 * std::sin(0.1 * i), 0.01 * (i % 3), 8.0 * i);
    data.gt_centres.push_back(c);
    data.est_centres.push_back(c);
    data.errors.push_back(0.0);
  }
  TrajectoryPlotLayout layout;
  PlotTrajectoryErrors(data, TrajectoryPlotOptions(), &layout);
  EXPECT_EQ(layout.axes, (std::array<int, 2>{0, 2}));
  TrajectoryPlotOptions fixed;
  fixed.axes = std::array<int, 2>{2, 1};
  PlotTrajectoryErrors(data, fixed, &layout);
  EXPECT_EQ(layout.axes, (std::array<int, 2>{2, 1}));
}

TEST(TrajectoryPlot, ColoursTheEstimateByItsErrorOverTheGreyDashedGroundTruth) {
  const TrajectoryPlotData data = Street();
  TrajectoryPlotOptions options;
  options.width = 800;
  options.height = 500;
  TrajectoryPlotLayout layout;
  const cv::Mat image = PlotTrajectoryErrors(data, options, &layout);
  ASSERT_EQ(image.type(), CV_8UC3);
  ASSERT_EQ(image.cols, 800);
  ASSERT_EQ(image.rows, 500);
  EXPECT_EQ(layout.axes, (std::array<int, 2>{0, 1}));

  // Every centre lies inside the image, 1 m apart across the street: equal scales.
  for (size_t i = 0; i < data.gt_centres.size(); ++i) {
    for (const Eigen::Vector3d& c : {data.gt_centres[i], data.est_centres[i]}) {
      const Eigen::Vector2d p = layout.ToPixel(c);
      EXPECT_TRUE(p.x() > 0 && p.y() > 0 && p.x() < image.cols && p.y() < image.rows) << p.transpose();
    }
  }
  const Eigen::Vector2d along = layout.ToPixel({1.0, 0.0, 0.0}) - layout.ToPixel({0.0, 0.0, 0.0});
  const Eigen::Vector2d across = layout.ToPixel({0.0, 1.0, 0.0}) - layout.ToPixel({0.0, 0.0, 0.0});
  EXPECT_NEAR(along.norm(), across.norm(), 1e-9);
  EXPECT_LT(across.y(), 0.0);  // the second axis points up

  // The estimate: the colour of a small error near its start, of a large one near its end
  // (segments take the mean error of their two poses).
  const Eigen::Vector2d start = 0.5 * (layout.ToPixel(data.est_centres[0]) +
                                       layout.ToPixel(data.est_centres[1]));
  const Eigen::Vector2d end = 0.5 * (layout.ToPixel(data.est_centres[39]) +
                                     layout.ToPixel(data.est_centres[40]));
  EXPECT_LT(ClosestColourDistance(image, start, TrajectoryPlotColour(0.0125)), 40);
  EXPECT_LT(ClosestColourDistance(image, end, TrajectoryPlotColour(0.9875)), 40);
  EXPECT_GT(ClosestColourDistance(image, start, TrajectoryPlotColour(0.9875)), 150);

  // The ground truth: grey dashes with light gaps along y = 0 (white, or the grid line there).
  int grey = 0, gap = 0;
  const cv::Vec3b reference_grey(150, 150, 150);
  for (double x = 1.0; x < 19.0; x += 0.05) {
    const Eigen::Vector2d p = layout.ToPixel({x, 0.0, 1.5});
    grey += ClosestColourDistance(image, p, reference_grey, 0) < 30;
    const cv::Vec3b pixel = image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y())),
                                                 static_cast<int>(std::lround(p.x())));
    gap += pixel[0] >= 200 && pixel[1] >= 200 && pixel[2] >= 200;
  }
  EXPECT_GT(grey, 100);
  EXPECT_GT(gap, 50);
}

TEST(TrajectoryPlot, SameInputSamePixels) {
  TrajectoryPlotOptions options;
  options.title = "APE";
  const cv::Mat a = PlotTrajectoryErrors(Street(), options);
  const cv::Mat b = PlotTrajectoryErrors(Street(), options);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST(TrajectoryPlot, DrawsEmptyConstantAndNonFiniteInput) {
  TrajectoryPlotOptions options;
  const cv::Mat empty = PlotTrajectoryErrors(TrajectoryPlotData(), options);
  EXPECT_EQ(empty.cols, options.width);
  EXPECT_EQ(empty.rows, options.height);

  TrajectoryPlotData one;
  one.gt_centres = {Eigen::Vector3d(1, 2, 3)};
  one.est_centres = {Eigen::Vector3d(1, 2, 3)};
  one.errors = {0.0};
  EXPECT_EQ(PlotTrajectoryErrors(one, options).rows, options.height);

  TrajectoryPlotData bad = Street();
  bad.est_centres[10] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  bad.errors[10] = std::numeric_limits<double>::quiet_NaN();
  TrajectoryPlotLayout layout;
  const cv::Mat image = PlotTrajectoryErrors(bad, options, &layout);
  EXPECT_TRUE(std::isfinite(layout.pixels_per_metre));
  EXPECT_EQ(image.rows, options.height);
}

TEST(TrajectoryPlot, ApeReportCarriesTheCentresItPlots) {
  // The report's centres are the ground truth's and the aligned estimate's, per entry.
  Trajectory gt, est;
  const slam::Sim3d est_from_gt(2.0, slam::ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3)),
                                Eigen::Vector3d(1, 2, 3));
  for (int i = 0; i < 20; ++i) {
    const slam::Rigid3d world_from_cam(slam::ExpSO3(Eigen::Vector3d(0, 0.1 * i, 0)),
                                       Eigen::Vector3d(i, std::sin(0.3 * i), 0.1 * i * i));
    gt.poses.push_back({0.1 * i, world_from_cam.Inverse()});
    est.poses.push_back({0.1 * i, slam::TransformPose(est_from_gt, world_from_cam.Inverse())});
  }
  TrajectoryErrorOptions options;
  options.alignment = TrajectoryAlignment::kSim3;
  const TrajectoryErrorReport report = ComputeApe(gt, est, options);
  ASSERT_FALSE(report.problem);
  ASSERT_EQ(report.gt_centres.size(), 20u);
  ASSERT_EQ(report.est_centres.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    EXPECT_LT((report.gt_centres[i] - gt.poses[i].cam_from_world.Center()).norm(), 1e-9);
    EXPECT_LT((report.est_centres[i] - report.gt_centres[i]).norm(), 1e-6);
  }
}

}  // namespace
}  // namespace lcv::mapping
