#include "mapping/eval/trajectory_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

// Margins around the plot area, pixels: room for the title, the tick labels and the colour bar.
constexpr int kMarginLeft = 70;
constexpr int kMarginRight = 120;
constexpr int kMarginTop = 50;
constexpr int kMarginBottom = 50;
constexpr double kPadding = 0.05;  // share of the data's extent left free around it

const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGridGrey(225, 225, 225);
const cv::Scalar kFrameGrey(120, 120, 120);
const cv::Scalar kReferenceGrey(150, 150, 150);

// A grid step of 1, 2 or 5 times a power of ten that cuts `extent` into about `cells` cells.
double NiceStep(double extent, int cells) {
  const double raw = extent / cells;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10.0 * power;
}

std::string FormatNumber(double value, double step) {
  // As many decimals as the step needs (0.25 -> 2, 5 -> 0).
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, std::abs(value) < step * 1e-6 ? 0.0 : value);
  return text;
}

std::string SignificantDigits(double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.3g", value);
  return text;
}

void PutText(cv::Mat* image, const std::string& text, cv::Point at, double scale = 0.45) {
  cv::putText(*image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, kBlack, 1, cv::LINE_AA);
}

int TextWidth(const std::string& text, double scale = 0.45) {
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width;
}

cv::Point Pixel(const TrajectoryPlotLayout& layout, const Eigen::Vector3d& world) {
  const Eigen::Vector2d p = layout.ToPixel(world);
  return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

// The grey dashed ground truth: dashes of 8 px with gaps of 8 px along the path's length (the
// round ends of the 2 px line take ~1 px of each gap).
void DrawDashedPath(cv::Mat* image, const std::vector<Eigen::Vector2d>& path) {
  constexpr double kDash = 8.0, kGap = 8.0;
  double phase = 0.0;  // position within the current dash + gap period
  for (size_t i = 1; i < path.size(); ++i) {
    const Eigen::Vector2d a = path[i - 1];
    const Eigen::Vector2d d = path[i] - a;
    const double length = d.norm();
    double s = 0.0;
    while (s < length) {
      const double left_in_period = phase < kDash ? kDash - phase : kDash + kGap - phase;
      const double step = std::min(left_in_period, length - s);
      if (phase < kDash) {
        const Eigen::Vector2d p = a + d * (s / length), q = a + d * ((s + step) / length);
        cv::line(*image, cv::Point2d(p.x(), p.y()), cv::Point2d(q.x(), q.y()), kReferenceGrey, 2,
                 cv::LINE_AA);
      }
      s += step;
      phase = std::fmod(phase + step, kDash + kGap);
    }
  }
}

}  // namespace

std::optional<std::array<int, 2>> ParsePlotAxes(const std::string& name) {
  if (name.size() != 2 || name[0] == name[1]) return std::nullopt;
  std::array<int, 2> axes{};
  for (int k = 0; k < 2; ++k) {
    if (name[k] < 'x' || name[k] > 'z') return std::nullopt;
    axes[k] = name[k] - 'x';
  }
  return axes;
}

cv::Vec3b TrajectoryPlotColour(double fraction) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(256, 1, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<unsigned char>(i) = static_cast<unsigned char>(i);
    cv::Mat colours;
    cv::applyColorMap(ramp, colours, cv::COLORMAP_VIRIDIS);
    return colours;
  }();
  const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  return lut.at<cv::Vec3b>(static_cast<int>(std::lround(f * 255.0)));
}

cv::Mat PlotTrajectoryErrors(const TrajectoryPlotData& data, const TrajectoryPlotOptions& options,
                             TrajectoryPlotLayout* layout_out) {
  LCV_CHECK(data.gt_centres.size() == data.est_centres.size() &&
            data.errors.size() == data.gt_centres.size())
      << "gt_centres, est_centres and errors differ in size";
  LCV_CHECK(options.width >= 320 && options.height >= 320)
      << "plot size " << options.width << "x" << options.height << " below 320x320";
  cv::Mat image(options.height, options.width, CV_8UC3, cv::Scalar(255, 255, 255));

  // The box of everything drawn (non-finite estimates are skipped when drawn, and here).
  bool empty = true;
  Eigen::Vector3d box_lo = Eigen::Vector3d::Zero(), box_hi = Eigen::Vector3d::Ones();
  auto grow = [&](const std::vector<Eigen::Vector3d>& points) {
    for (const Eigen::Vector3d& p : points) {
      if (!p.allFinite()) continue;
      box_lo = empty ? p : box_lo.cwiseMin(p);
      box_hi = empty ? p : box_hi.cwiseMax(p);
      empty = false;
    }
  };
  grow(data.reference_path);
  grow(data.gt_centres);
  grow(data.est_centres);

  TrajectoryPlotLayout layout;
  if (options.axes) {
    layout.axes = *options.axes;
  } else if (!empty) {
    int smallest = 0;
    (box_hi - box_lo).minCoeff(&smallest);
    layout.axes = smallest == 0 ? std::array<int, 2>{1, 2}
                  : smallest == 1 ? std::array<int, 2>{0, 2}
                                  : std::array<int, 2>{0, 1};
  }
  const int u = layout.axes[0], v = layout.axes[1];

  // Equal scales: the data's box, padded, fitted into the plot area and centred in it.
  const cv::Rect area(kMarginLeft, kMarginTop, options.width - kMarginLeft - kMarginRight,
                      options.height - kMarginTop - kMarginBottom);
  const Eigen::Vector2d lo(box_lo[u], box_lo[v]), hi(box_hi[u], box_hi[v]);
  Eigen::Vector2d extent = hi - lo;
  const double span = std::max({extent.x(), extent.y(), 1e-3});
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  extent = extent.cwiseMax(Eigen::Vector2d::Constant(0.1 * span)) * (1.0 + 2.0 * kPadding);
  layout.pixels_per_metre = std::min(area.width / extent.x(), area.height / extent.y());
  layout.origin_px = Eigen::Vector2d(area.x + 0.5 * area.width - layout.pixels_per_metre * centre.x(),
                                     area.y + 0.5 * area.height + layout.pixels_per_metre * centre.y());

  // Grid and tick labels, metres.
  const double metres_per_px = 1.0 / layout.pixels_per_metre;
  const double step = NiceStep(std::max(area.width, area.height) * metres_per_px, 10);
  const double u_min = (area.x - layout.origin_px.x()) * metres_per_px;
  const double u_max = (area.x + area.width - layout.origin_px.x()) * metres_per_px;
  const double v_min = (layout.origin_px.y() - area.y - area.height) * metres_per_px;
  const double v_max = (layout.origin_px.y() - area.y) * metres_per_px;
  for (double g = std::ceil(u_min / step) * step; g <= u_max; g += step) {
    const int x = static_cast<int>(std::lround(layout.origin_px.x() + g * layout.pixels_per_metre));
    cv::line(image, {x, area.y}, {x, area.y + area.height}, kGridGrey, 1);
    const std::string label = FormatNumber(g, step);
    PutText(&image, label, {x - TextWidth(label) / 2, area.y + area.height + 18});
  }
  for (double g = std::ceil(v_min / step) * step; g <= v_max; g += step) {
    const int y = static_cast<int>(std::lround(layout.origin_px.y() - g * layout.pixels_per_metre));
    cv::line(image, {area.x, y}, {area.x + area.width, y}, kGridGrey, 1);
    const std::string label = FormatNumber(g, step);
    PutText(&image, label, {area.x - 6 - TextWidth(label), y + 5});
  }
  cv::rectangle(image, area, kFrameGrey, 1);
  const char* names[] = {"x", "y", "z"};
  PutText(&image, std::string(names[u]) + " (m)", {area.x + area.width / 2 - 15, options.height - 10});
  PutText(&image, std::string(names[v]) + " (m)", {8, area.y - 8});
  if (!options.title.empty()) PutText(&image, options.title, {area.x, 22}, 0.55);

  // Everything below is clipped to the plot area.
  cv::Mat plot = image(area);
  TrajectoryPlotLayout in_area = layout;
  in_area.origin_px -= Eigen::Vector2d(area.x, area.y);

  std::vector<Eigen::Vector2d> reference;
  for (const Eigen::Vector3d& p : data.reference_path.empty() ? data.gt_centres
                                                              : data.reference_path) {
    reference.push_back(in_area.ToPixel(p));
  }
  DrawDashedPath(&plot, reference);

  double e_min = std::numeric_limits<double>::infinity(), e_max = -e_min;
  for (const double e : data.errors) {
    if (!std::isfinite(e)) continue;
    e_min = std::min(e_min, e);
    e_max = std::max(e_max, e);
  }
  const bool have_errors = e_min <= e_max;
  auto fraction = [&](double e) { return e_max > e_min ? (e - e_min) / (e_max - e_min) : 0.5; };
  for (size_t i = 1; i < data.est_centres.size(); ++i) {
    if (!data.est_centres[i - 1].allFinite() || !data.est_centres[i].allFinite()) continue;
    const cv::Vec3b c = TrajectoryPlotColour(fraction(0.5 * (data.errors[i - 1] + data.errors[i])));
    cv::line(plot, Pixel(in_area, data.est_centres[i - 1]), Pixel(in_area, data.est_centres[i]),
             cv::Scalar(c[0], c[1], c[2]), 2, cv::LINE_AA);
  }
  if (!reference.empty()) {
    const cv::Point start(static_cast<int>(std::lround(reference.front().x())),
                          static_cast<int>(std::lround(reference.front().y())));
    cv::circle(plot, start, 5, kBlack, 1, cv::LINE_AA);
    PutText(&plot, "start", start + cv::Point(8, -6), 0.4);
  }

  // Colour bar: the largest error at the top.
  const cv::Rect bar(options.width - kMarginRight + 30, area.y + 20, 18, area.height - 40);
  for (int row = 0; row < bar.height; ++row) {
    const cv::Vec3b c = TrajectoryPlotColour(1.0 - static_cast<double>(row) / (bar.height - 1));
    cv::line(image, {bar.x, bar.y + row}, {bar.x + bar.width - 1, bar.y + row},
             cv::Scalar(c[0], c[1], c[2]), 1);
  }
  cv::rectangle(image, bar, kFrameGrey, 1);
  PutText(&image, options.error_label, {bar.x - 10, bar.y - 8});
  if (have_errors) {
    PutText(&image, SignificantDigits(e_max), {bar.x + bar.width + 4, bar.y + 5}, 0.4);
    PutText(&image, SignificantDigits(0.5 * (e_min + e_max)),
            {bar.x + bar.width + 4, bar.y + bar.height / 2 + 5}, 0.4);
    PutText(&image, SignificantDigits(e_min), {bar.x + bar.width + 4, bar.y + bar.height + 5}, 0.4);
  }
  if (layout_out != nullptr) *layout_out = layout;
  return image;
}

}  // namespace lcv::mapping
